"""The HOAP-2 nominal numbers: derived from the Webots proto (hoap2/webots_hoap2.toml) by
hoap2/lump.py, generated into hoap2/include/hoap2/nominal.h, and used unchanged as the defaults of
both FMUs.

Establishes: the committed header is exactly the script's output (one source of truth); the
lumping conserves mass, first moments and pitch inertia (the lumps recombine to the whole robot
computed body by body); the derivation reproduces the independent review's figures (lg1 = 0.154 m,
not the 0.138 m that was a per-leg first moment in kg m; feet CoM 4.7 mm / 24 mm); and every model
parameter of the controller and plant FMUs starts at the header's value.
"""
from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from conftest import NOMINAL, REPO_ROOT, import_file
from anklehip.running.fmu import FMUInfo

lump = import_file(REPO_ROOT / "hoap2" / "lump.py", "hoap2_lump")


@pytest.fixture(scope="module")
def derived():
    return lump.lumped()


def test_header_is_the_scripts_output():
    assert lump.HEADER.read_text() == lump.header_text(), "stale header: run python3 hoap2/lump.py --write"
    r = subprocess.run([sys.executable, str(REPO_ROOT / "hoap2" / "lump.py"), "--check"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def test_header_values_round_the_derivation(derived):
    for macro, key, _ in lump.MACROS:
        assert NOMINAL[macro] == pytest.approx(derived[key], rel=5e-6, abs=1e-12), macro


def test_lumping_conserves_mass_first_moment_and_inertia(derived):
    data = lump.load()
    bodies = lump.place(data)
    total = sum(b["mass"] for b in data["body"])
    assert derived["total_mass"] == pytest.approx(total, rel=1e-15)
    assert total == pytest.approx(7.16, abs=0.005)          # the proto's "7 kg" robot
    groups = {g: lump.lump([b for b in bodies.values() if lump.group_of(b.name) == g])
              for g in ("feet", "link1", "link2")}
    assert sum(g.mass for g in groups.values()) == pytest.approx(total, rel=1e-14)
    whole = lump.lump(list(bodies.values()))
    c = sum(g.mass * g.com for g in groups.values()) / total
    assert np.allclose(c, whole.com, atol=1e-15)
    # pitch inertia about the whole CoM: lumps (own + parallel axis) = body by body
    iyy = sum(g.Iyy + g.mass * ((g.com[0] - c[0]) ** 2 + (g.com[2] - c[2]) ** 2) for g in groups.values())
    assert iyy == pytest.approx(whole.Iyy, rel=1e-12)


def test_derivation_reproduces_the_independent_review(derived):
    """Figures of the physics review (issue 9), lumped independently from the same proto."""
    assert derived["m1"] == pytest.approx(1.794, abs=5e-4)
    assert derived["m2"] == pytest.approx(4.71, abs=5e-4)
    assert derived["feet_mass"] == pytest.approx(0.656, abs=5e-4)
    assert derived["lg1"] == pytest.approx(0.154, abs=5e-4)
    # the old 0.138 was the per-leg first moment sum(m z) in kg m, not a length
    per_leg_moment = derived["m1"] / 2 * derived["lg1"]
    assert per_leg_moment == pytest.approx(0.138, abs=5e-4)
    assert derived["I1"] == pytest.approx(0.010, abs=5e-4)
    assert derived["I2"] == pytest.approx(0.025, rel=0.3)    # review: rough, +-30 %
    assert derived["feet_com_x"] == pytest.approx(0.0047, abs=1e-4)
    assert derived["feet_com_z"] == pytest.approx(0.024, abs=5e-4)
    assert (derived["l1"], derived["toe_x"], derived["heel_x"], derived["ankle_height"]) == pytest.approx(
        (0.2, 0.0575, -0.0375, 0.035), abs=1e-12)


def test_posture_hangs_the_arms_and_leaves_the_legs_straight():
    bodies = lump.place(lump.load())
    for side in ("larm", "rarm"):
        shoulder = np.array(bodies[f"{side}_shoulder_pitch"].joint["anchor"])
        hand = bodies[f"{side}_hand"].com
        assert hand[2] == pytest.approx(shoulder[2] - 0.201, abs=1e-3)    # 0.101 + 0.1 straight down
        assert hand[0] == pytest.approx(shoulder[0], abs=1e-3)
    for side in ("lleg", "rleg"):
        hip = np.array(bodies[f"{side}_hip_pitch"].joint["anchor"])
        ankle = np.array(bodies[f"{side}_ankle_pitch"].joint["anchor"])
        assert np.allclose(hip - ankle, [0, 0, 0.2], atol=1e-15)
    # arms forward (the proto's zero pose) would move link 2's CoM ~20 mm forward: the posture matters
    forward = lump.place(lump.load(), posture={})
    c2 = lump.lump([b for b in forward.values() if lump.group_of(b.name) == "link2"]).com
    assert c2[0] - (-0.034) > 0.015
    with pytest.raises(ValueError, match="unknown joints"):
        lump.place(lump.load(), posture={"nosuch_joint": 1.0})


def test_rotation_is_right_handed_like_webots():
    # +pi/2 about +y turns +x into -z (a forward-pointing arm hangs down)
    assert np.allclose(lump.rotation([0, 1, 0], math.pi / 2) @ [1, 0, 0], [0, 0, -1], atol=1e-15)


def test_json_lists_every_body():
    r = subprocess.run([sys.executable, str(REPO_ROOT / "hoap2" / "lump.py"), "--json"], capture_output=True,
                       text=True, check=True)
    out = json.loads(r.stdout)
    assert len(out["bodies"]) == len(lump.load()["body"]) == 28
    assert out["sagittal"]["lg1"] == pytest.approx(lump.lumped()["lg1"])


# FMU parameter name -> nominal.h macro
SHARED = {"g": "G", "m1": "M1", "l1": "L1", "lg1": "LG1", "I1": "I1", "m2": "M2", "lg2": "LG2", "I2": "I2",
          "feet_mass": "FEET_MASS", "feet_com_x": "FEET_COM_X", "feet_com_z": "FEET_COM_Z", "toe_x": "TOE_X",
          "heel_x": "HEEL_X", "ankle_height": "ANKLE_HEIGHT"}


@pytest.mark.parametrize("fmu,extra", [
    ("AnkleHipController", {"ankle_min": "ANKLE_MIN", "ankle_max": "ANKLE_MAX", "hip_min": "HIP_MIN",
                            "hip_max": "HIP_MAX", "sample_period": "SAMPLE_PERIOD"}),
    ("Hoap2Plant", {"feet_inertia": "FEET_INERTIA"}),
    # the 3D controller: the sagittal FMU's numbers and the frontal plane's (issue 29)
    ("AnkleHipController3D", {"ankle_min": "ANKLE_MIN", "ankle_max": "ANKLE_MAX", "hip_min": "HIP_MIN",
                              "hip_max": "HIP_MAX", "sample_period": "SAMPLE_PERIOD", "hip_y": "HIP_Y",
                              "ankle_y": "ANKLE_Y", "thigh": "THIGH", "shank": "SHANK", "I1_roll": "I1_ROLL",
                              "I2_roll": "I2_ROLL", "link1_com_y": "LINK1_COM_Y", "link2_com_y": "LINK2_COM_Y",
                              "sole_width": "SOLE_WIDTH", "ankle_roll_max": "ANKLE_ROLL_MAX",
                              "hip_abduction_max": "HIP_ABDUCTION_MAX", "hip_adduction_max": "HIP_ADDUCTION_MAX",
                              "knee_max": "KNEE_MAX"}),
])
def test_fmu_defaults_are_the_nominal_numbers(fmu_path, fmu, extra):
    params = FMUInfo.load(fmu_path(fmu)).parameters()
    for name, macro in {**SHARED, **extra}.items():
        assert float(params[name].start) == NOMINAL[macro], f"{fmu}.{name}"
