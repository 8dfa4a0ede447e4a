"""A scenario on another robot: both FMUs' parameters from a robot file (gains scaled,
anklehip.robot.scaling) and the experiment carried over in the robot's own units.

A scenario's pushes are written for a robot: the one its key ``robot`` names, else the FMUs'
defaults (HOAP-2). Run on another robot (``anklehip run ... --robot FILE``), every push keeps its
fraction of the static tipping force (pushes on the back scale with the back's, on the chest with
the chest's) and every time its number of pendulum time constants T_p = sqrt(l_g / g): push
times, durations and rises, the stop time (rounded up to whole steps), the expectations' times.
Lengths the expectations bound along the sole (max_abs_zmp) scale with the toe. The
communication step stays (the control period).

``push_units = "robot"`` writes a scenario in those units directly: forces as fractions of the
static tipping force, times (push program, stop_time, expectations) in T_p. It means the same
experiment on every robot.
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ..analysis.bounds import robot_from_plant_params, static_tipping_force
from ..running.master import check_overrides
from ..files.scenario import PushProfile, PushSegment, Scenario, ScenarioError, time_grid_problem
from .robotfile import Robot, load_robot
from .scaling import Scaled, Scales, scale


@dataclass
class RobotRun:
    """What running a scenario on a robot changed, for the summary."""
    robot: Robot
    scaled: Scaled
    T_p: float                     # the robot's pendulum time constant [s]
    tipping: tuple[float, float]   # static tipping force, back / chest [N]
    time_factor: float             # scenario seconds -> robot seconds
    force_factor: tuple[float, float]

    def summary(self) -> dict[str, Any]:
        s = self.scaled
        return {"name": self.robot.name, "file": str(self.robot.path) if self.robot.path else None,
                "mass_kg": self.robot.total_mass, "com_height_m": s.robot.l_g, "pendulum_time_s": self.T_p,
                "static_tipping_force_N": list(self.tipping), "toe_x_m": s.robot.toe, "heel_x_m": s.robot.heel,
                "time_factor": self.time_factor, "force_factor": list(self.force_factor),
                "parameters": {"controller": s.controller, "plant": s.plant}}


def find_robot(name_or_path: str | Path) -> Path:
    """A robot file given by path, or by name (robots/<name>.toml in the checkout)."""
    from ..files.paths import MissingFileError, _find_toml, repo_root
    return _find_toml(str(name_or_path), repo_root() / "robots", "robot")


def tipping_forces(plant_params: dict[str, Any]) -> tuple[float, float]:
    r = robot_from_plant_params(plant_params)
    return static_tipping_force(r, +1), static_tipping_force(r, -1)


def pendulum_time(params: dict[str, Any]) -> float:
    return Scales.of({k: float(params[k]) for k in ("g", "m1", "l1", "lg1", "I1", "m2", "lg2", "I2", "feet_mass",
                                                    "toe_x", "heel_x")}).T_p


def rescale_scenario(sc: Scenario, k_t: float, k_back: float, k_chest: float, k_x: float) -> Scenario:
    """The scenario with its push forces scaled (positive levels by k_back, negative by k_chest), its
    times by k_t and its sole lengths by k_x."""
    def force(f):
        return None if f is None else f * (k_back if f >= 0 else k_chest)

    def profile(p: PushProfile) -> PushProfile:
        if not p.segments:
            return p
        segs = [replace(s, t=None if s.t is None else s.t * k_t, duration=s.duration * k_t, rise=s.rise * k_t,
                        to=force(s.to), force=force(s.force),
                        impulse=None if s.impulse is None else s.impulse * k_t * (k_back if s.impulse >= 0 else k_chest))
                for s in p.segments]
        return PushProfile.from_segments(segs)

    out = copy.copy(sc)
    out.push, out.push_y = profile(sc.push), profile(sc.push_y)
    n = math.ceil(sc.stop_time * k_t / sc.step - 1e-9)
    out.stop_time = n * sc.step
    e = copy.copy(sc.expect)
    for k in ("fall_after", "fall_before", "erect_by"):
        if getattr(e, k) is not None:
            setattr(e, k, min(getattr(e, k) * k_t, out.stop_time))
    if e.max_abs_zmp is not None:
        e.max_abs_zmp *= k_x
    out.expect = e
    f = sc.faults
    out.faults = replace(f, stuck_for=f.stuck_for * k_t,
                         stuck_at=None if f.stuck_at is None else [t * k_t for t in f.stuck_at],
                         transition_push=force(f.transition_push), transition_push_duration=f.transition_push_duration * k_t,
                         transition_push_rise=f.transition_push_rise * k_t, zmp_noise=f.zmp_noise * k_x,
                         zmp_bias=f.zmp_bias * k_x)
    problem = time_grid_problem(out.stop_time, out.step)
    if problem:
        raise ScenarioError(f"{sc.path or sc.name}: on this robot the stop time {out.stop_time:g} s {problem}")
    return out


def apply_robot(sc: Scenario, models, robot: str | Path | Robot | None = None) -> Scenario:
    """`sc` on `robot` (default: the scenario's key `robot`): a new Scenario whose [controller] and
    [plant] tables start from the robot's parameters (the scenario's own tables on top) and whose
    experiment is carried over (module docstring). The FMUs' defaults are the anchor."""
    c_start = models.controller.start_values()
    c_anchor = {**c_start, **models.controller.configuration(sc.controller_config, f"{sc.path or sc.name}: controller_config")}
    p_anchor = models.plant.start_values()
    anchor_T = pendulum_time(c_anchor)
    anchor_tip = tipping_forces({**p_anchor, **c_anchor})

    def robot_params(rb: Robot) -> Scaled:
        s = scale(rb, c_anchor, p_anchor)
        # the FMUs' ranges, naming the robot file (before anything runs)
        check_overrides(models, s.controller, s.plant, f"robot file {rb.where()} (scaled)")
        return s

    written_for = load_robot(find_robot(sc.robot)) if sc.robot else None
    target = robot if isinstance(robot, Robot) else (load_robot(find_robot(robot)) if robot else written_for)
    if target is None:
        if sc.push_units != "robot":
            return sc
        target_scaled, T, tip = None, anchor_T, anchor_tip
    else:
        target_scaled = robot_params(target)
        T, tip = pendulum_time(target_scaled.controller), tipping_forces(target_scaled.plant)
    if sc.push_units == "robot":             # fractions of the tipping force and T_p
        k_t, k_b, k_c = T, tip[0], tip[1]
        k_x = 1.0
        base_toe = None
    else:
        if written_for is not None:
            ws = robot_params(written_for)
            T0, tip0, toe0 = pendulum_time(ws.controller), tipping_forces(ws.plant), written_for.value("toe_x")
        else:
            T0, tip0, toe0 = anchor_T, anchor_tip, float(c_anchor["toe_x"])
        k_t, k_b, k_c = T / T0, tip[0] / tip0[0], tip[1] / tip0[1]
        base_toe = toe0
    toe = target.value("toe_x") if target is not None else float(c_anchor["toe_x"])
    k_x = toe / base_toe if base_toe else k_x
    out = rescale_scenario(sc, k_t, k_b, k_c, k_x) if (k_t, k_b, k_c, k_x) != (1.0, 1.0, 1.0, 1.0) else copy.copy(sc)
    if target_scaled is not None:
        out.controller = {**target_scaled.controller, **sc.controller}
        out.plant = {**target_scaled.plant, **sc.plant}
        out.robot_run = RobotRun(target, target_scaled, T, tip, k_t, (k_b, k_c))
    out.push_units = "SI"
    out.robot = None
    return out
