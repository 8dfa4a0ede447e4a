"""Robot files (TOML): a humanoid's sagittal model for the controller and the sagittal plant, every
number with its unit and where it came from (docs/your-robot.md).

    [model]      the numbers both FMUs take (SI): masses, lengths, inertias, sole, joint limits
    [servo]      joint torque and rate limits (both legs together), where the description gives them
    [info]       reported, not used by the models (what was neglected, which joints and links)

Each number is an inline table ``{ value = ..., unit = "...", source = "..." }``. A file that makes
no physical sense (a negative mass, the CoM below the sole, a sole of zero length, ...) is refused
with a RobotFileError naming the file and the field.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..files.text import read_toml
from ..files.scenario import ScenarioError

FORMAT = 1


class RobotFileError(ScenarioError):
    """A robot file (or a description being lumped) is wrong; the message names file and field.
    Wrong input like a wrong scenario (the command line exits 2)."""


@dataclass(frozen=True)
class Field:
    unit: str
    doc: str
    required: bool = True


# The sagittal model (docs/hoap2-model.md, docs/controller.md section 1): the names of the FMUs'
# parameters, x forward from the ankle pitch axis, heights above the sole unless stated.
MODEL = {
    "g": Field("m/s2", "gravitational acceleration"),
    "m1": Field("kg", "link 1: both legs between the ankle and hip pitch axes"),
    "l1": Field("m", "ankle pitch axis -> hip pitch axis"),
    "lg1": Field("m", "ankle pitch axis -> CoM of link 1, along the link"),
    "I1": Field("kg.m2", "pitch inertia of link 1 about its CoM"),
    "m2": Field("kg", "link 2: everything above the hip pitch axes"),
    "lg2": Field("m", "hip pitch axis -> CoM of link 2, along the link"),
    "I2": Field("kg.m2", "pitch inertia of link 2 about its CoM"),
    "feet_mass": Field("kg", "both feet: everything below the ankle pitch axes"),
    "feet_com_x": Field("m", "CoM of the feet, x forward of the ankle axis"),
    "feet_com_z": Field("m", "CoM of the feet, height above the sole"),
    "feet_inertia": Field("kg.m2", "pitch inertia of both feet about their CoM"),
    "toe_x": Field("m", "toe edge of the sole, x from the ankle axis"),
    "heel_x": Field("m", "heel edge of the sole, x from the ankle axis"),
    "ankle_height": Field("m", "ankle pitch axis above the sole"),
    "sole_width": Field("m", "width of one sole"),
    "ankle_min": Field("rad", "ankle pitch lower limit (theta1, + = the leg pitches forward)"),
    "ankle_max": Field("rad", "ankle pitch upper limit"),
    "hip_min": Field("rad", "hip pitch lower limit (theta2, + = the trunk pitches forward)"),
    "hip_max": Field("rad", "hip pitch upper limit"),
    "sample_period": Field("s", "control period"),
}
# Servo limits of both legs together; a description without them leaves them out (the scaling rule
# then scales HOAP-2's, anklehip.robot.scaling).
SERVO = {
    "tau_max_ankle": Field("N.m", "ankle pitch torque limit, both legs", required=False),
    "tau_max_hip": Field("N.m", "hip pitch torque limit, both legs", required=False),
    "vel_max_ankle": Field("rad/s", "ankle pitch rate limit", required=False),
    "vel_max_hip": Field("rad/s", "hip pitch rate limit", required=False),
}
SECTIONS = {"model": MODEL, "servo": SERVO}


@dataclass
class Quantity:
    value: float
    unit: str
    source: str


@dataclass
class Robot:
    """A robot file in memory. `model` and `servo` hold Quantity's; `info` is free-form (reported)."""
    name: str
    model: dict[str, Quantity]
    servo: dict[str, Quantity] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)
    source: dict[str, Any] = field(default_factory=dict)
    path: Path | None = None

    def value(self, key: str) -> float:
        return self.model[key].value if key in self.model else self.servo[key].value

    def values(self) -> dict[str, float]:
        """Every number of [model] and [servo], by name (SI)."""
        return {k: q.value for k, q in {**self.model, **self.servo}.items()}

    # derived figures of the sagittal model (docs/controller.md section 1)
    @property
    def body_mass(self) -> float:
        """m = m1 + m2 (the two-link body above the ankles)."""
        return self.value("m1") + self.value("m2")

    @property
    def total_mass(self) -> float:
        return self.body_mass + self.value("feet_mass")

    @property
    def com_height(self) -> float:
        """Erect CoM height of the two-link body above the ankle axis, r_z = (m1 lg1 + m2 (l1 + lg2)) / m:
        the pendulum length l_g of the scaling rule."""
        v = self.values()
        return (v["m1"] * v["lg1"] + v["m2"] * (v["l1"] + v["lg2"])) / self.body_mass

    def where(self) -> str:
        return str(self.path) if self.path else f"robot {self.name!r}"

    def to_toml(self, header: str = "") -> str:
        out = [f"# {line}".rstrip() for line in header.splitlines()] if header else []
        out += [f"format = {FORMAT}", f"name = {_toml_str(self.name)}", ""]
        if self.source:
            out.append("[source]")
            out += [f"{k} = {_toml_value(v)}" for k, v in self.source.items()]
            out.append("")
        for sec, fields in SECTIONS.items():
            q = getattr(self, sec)
            if not q:
                continue
            out.append(f"[{sec}]")
            for k in fields:
                if k in q:
                    x = q[k]
                    out.append(f"{k} = {{ value = {_num(x.value)}, unit = {_toml_str(x.unit)}, "
                               f"source = {_toml_str(x.source)} }}")
            out.append("")
        if self.info:
            out.append("[info]")
            out += [f"{k} = {_toml_value(v)}" for k, v in self.info.items()]
            out.append("")
        return "\n".join(out)

    def write(self, path: str | Path, header: str = "") -> Path:
        """Write the robot file (atomically: a temporary file renamed)."""
        path = Path(path)
        tmp = path.with_name(path.name + ".tmp")
        tmp.write_text(self.to_toml(header))
        os.replace(tmp, path)
        return path


def _num(x: float) -> str:
    """A float as TOML that reads back to the same double."""
    s = repr(float(x))
    return s if ("." in s or "e" in s or "inf" in s or "nan" in s) else s + ".0"


def _toml_str(s: str) -> str:
    return '"' + str(s).replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n") + '"'


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int,)) and not isinstance(v, bool):
        return str(v)
    if isinstance(v, float):
        return _num(v)
    if isinstance(v, str):
        return _toml_str(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def _key(k: str) -> str:
    return k if k.replace("_", "").replace("-", "").isalnum() else _toml_str(k)


# ----------------------------------------------------------------------------------------------
# reading and checking

def load_robot(path: str | Path) -> Robot:
    """Read and check a robot file; RobotFileError naming the file and the field when it is wrong."""
    path = Path(path)
    where = str(path)
    data = read_toml(path, where, RobotFileError)
    return parse_robot(data, where, path)


def parse_robot(data: dict, where: str = "<robot>", path: Path | None = None) -> Robot:
    def fail(key: str, msg: str):
        raise RobotFileError(f"{where}: {key}: {msg}")

    known = {"format", "name", "source", "model", "servo", "info"}
    for k in data:
        if k not in known:
            fail(k, f"unknown key (allowed: {', '.join(sorted(known))})")
    if data.get("format", FORMAT) != FORMAT:
        fail("format", f"this anklehip reads robot files of format {FORMAT}, got {data.get('format')!r}")
    name = data.get("name", path.stem if path else "robot")
    if not isinstance(name, str) or not name:
        fail("name", f"must be a non-empty string, got {name!r}")
    sections: dict[str, dict[str, Quantity]] = {}
    for sec, fields in SECTIONS.items():
        tab = data.get(sec, {})
        if not isinstance(tab, dict):
            fail(sec, "must be a table")
        got: dict[str, Quantity] = {}
        for k, v in tab.items():
            key = f"{sec}.{k}"
            if k not in fields:
                fail(key, f"unknown quantity (known: {', '.join(fields)})")
            if isinstance(v, dict):
                extra = set(v) - {"value", "unit", "source"}
                if extra:
                    fail(key, f"unknown key(s) {', '.join(sorted(extra))} (allowed: value, unit, source)")
                if "value" not in v:
                    fail(f"{key}.value", "required key missing")
                val, unit, src = v["value"], v.get("unit", fields[k].unit), v.get("source", "")
            else:
                val, unit, src = v, fields[k].unit, ""
            if isinstance(val, bool) or not isinstance(val, (int, float)):
                fail(key, f"must be a number [{fields[k].unit}], got {val!r}")
            if not math.isfinite(float(val)):
                fail(key, f"must be finite, got {val}")
            if unit != fields[k].unit:
                fail(f"{key}.unit", f"must be {fields[k].unit!r} (SI), got {unit!r}")
            if not isinstance(src, str):
                fail(f"{key}.source", f"must be a string, got {src!r}")
            got[k] = Quantity(float(val), unit, src)
        for k, f in fields.items():
            if f.required and k not in got:
                fail(f"{sec}.{k}", f"required quantity missing ({f.doc} [{f.unit}])")
        sections[sec] = got
    info = data.get("info", {})
    source = data.get("source", {})
    for k, v in (("info", info), ("source", source)):
        if not isinstance(v, dict):
            fail(k, "must be a table")
    robot = Robot(name, sections["model"], sections["servo"], info, source, path)
    check_physics(robot, where)
    return robot


def physics_problems(v: dict[str, float]) -> list[tuple[str, str]]:
    """(field, why) for each number of a sagittal model that makes no physical sense."""
    out: list[tuple[str, str]] = []

    def need(ok: bool, key: str, why: str):
        if not ok:
            out.append((key, why))

    def sec(k: str) -> str:
        return f"servo.{k}" if k in SERVO else f"model.{k}"

    for k in ("g", "m1", "m2", "l1", "lg2", "toe_x", "ankle_height", "sole_width", "sample_period"):
        need(v[k] > 0, sec(k), f"must be > 0, got {v[k]:g} {MODEL[k].unit}")
    need(v["feet_mass"] >= 0, "model.feet_mass", f"must be >= 0, got {v['feet_mass']:g} kg")
    for k in ("I1", "I2", "feet_inertia"):
        need(v[k] >= 0, f"model.{k}", f"an inertia must be >= 0, got {v[k]:g} kg.m2")
    need(v["heel_x"] < 0, "model.heel_x", f"the heel must be behind the ankle axis (< 0), got {v['heel_x']:g} m")
    need(v["toe_x"] - v["heel_x"] > 0, "model.toe_x",
         f"the sole has zero or negative length: toe_x {v['toe_x']:g} m, heel_x {v['heel_x']:g} m")
    need(0 < v["lg1"] <= v["l1"], "model.lg1",
         f"the CoM of link 1 must lie on the link, 0 < lg1 <= l1 = {v['l1']:g} m, got {v['lg1']:g} m")
    need(v["feet_com_z"] >= 0, "model.feet_com_z", f"the feet's CoM lies below the sole ({v['feet_com_z']:g} m)")
    m = v["m1"] + v["m2"]
    if m > 0:
        rz = (v["m1"] * v["lg1"] + v["m2"] * (v["l1"] + v["lg2"])) / m
        need(rz + v["ankle_height"] > 0, "model.lg2",
             f"the CoM lies below the sole ({rz + v['ankle_height']:g} m above it)")
        need(rz > 0, "model.lg2", f"the CoM lies below the ankle axis ({rz:g} m above it): not an inverted pendulum")
    for j in ("ankle", "hip"):
        lo, hi = v[f"{j}_min"], v[f"{j}_max"]
        need(lo < 0 < hi, f"model.{j}_min",
             f"the erect posture (0) must lie inside the {j} pitch limits, got [{lo:g}, {hi:g}] rad")
    for k in SERVO:
        if k in v:
            need(v[k] > 0, f"servo.{k}", f"must be > 0, got {v[k]:g} {SERVO[k].unit}")
    return out


def check_physics(robot: Robot, where: str | None = None) -> None:
    probs = physics_problems(robot.values())
    if probs:
        k, why = probs[0]
        more = f" (and {len(probs) - 1} more: {', '.join(p[0] for p in probs[1:])})" if len(probs) > 1 else ""
        raise RobotFileError(f"{where or robot.where()}: {k}: {why}{more}")
