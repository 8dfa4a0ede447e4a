"""The named configuration `omnidirectional` (docs/controller.md §4.7): the 3D controller with the
sagittal pendulum lean, on the 3D plant, on the polar map's pushes (scenarios/sweeps/polar_3d.toml:
one pulse at 2 s with 50 ms ramps, 6 s runs, on paper_five_pushes_3d).

- 1 s pulses on the sagittal axis at 80 % of the static tipping force, rounded up to the polar map's
  1 N grid (12.0 N on the back: 10 N; 8.0 N on the chest: 7 N): the configuration stands them, the
  defaults (the paper's sagittal law) fall. The static forces come from anklehip.analysis.bounds, not
  typed here.
- A 0.2 s pulse on the back at 16 N, which the defaults stand (19 N), stands too: the lean costs
  short pulses on the back a few newtons, not their boundary's bulk.
- The configuration is what configurations.toml says of it, in both controller FMUs.
"""
from __future__ import annotations

import math

import pytest

from anklehip.files.paths import find_sweep_file
from anklehip.running import native
from anklehip.running.sweep import Variant
from anklehip.running.sweepfile import load_sweep_file, sweepfile_point

CONFIG = "omnidirectional"


@pytest.fixture(scope="module")
def polar():
    return load_sweep_file(find_sweep_file("polar_3d"))


def _stands(sf, fmu_dir, config, angle, duration, force) -> bool:
    v = Variant("t", {}, {}, config, "3d")
    spec = {"sweep": str(sf.path), "fmu_dir": str(fmu_dir), "engine": native.default_engine(), "variant": v.as_dict(),
            "values": {"push.angle": angle, "push.force": force, "push.duration": duration}}
    return sweepfile_point(spec)["outcome"] == "completed"


def _static(sf, fmu_dir, angle) -> float:
    from anklehip.analysis.bounds import static_tipping_force_3d
    from anklehip.analysis.capability import stance_of
    from anklehip.files.scenario import load_scenario
    from anklehip.running.sweep import bounds_parameters_of, cached_models
    v = Variant("bounds", {}, {}, None, "3d")
    sc = v.apply(load_scenario(sf.scenario))
    st = stance_of(bounds_parameters_of(cached_models(str(fmu_dir), sc.plant_model, sc.controller_model), sc, v))
    return float(static_tipping_force_3d(st, angle))


@pytest.mark.parametrize("angle", [0.0, 180.0])
def test_one_second_pulse_at_80_percent_of_static(polar, fmu_dir, angle):
    force = math.ceil(0.8 * _static(polar, fmu_dir, angle) - 1e-9)
    assert force == {0.0: 10, 180.0: 7}[angle]     # the grid forces the docs name
    assert _stands(polar, fmu_dir, CONFIG, angle, 1.0, force)
    assert not _stands(polar, fmu_dir, None, angle, 1.0, force)


def test_short_pulse_on_the_back(polar, fmu_dir):
    assert _stands(polar, fmu_dir, CONFIG, 0.0, 0.2, 16.0)


def test_configurations_toml_names_it(fmu_dir):
    import zipfile
    for fmu in ("AnkleHipController.fmu", "AnkleHipController3D.fmu"):
        with zipfile.ZipFile(fmu_dir / fmu) as z:
            text = z.read("resources/configurations.toml").decode()
        block = text.split(f"[{CONFIG}]", 1)[1].split("\n[", 1)[0]
        for row in ("lean_enabled = 1", "lean_law = 1", "lean_tau = 0.03", "lean_margin = 0.0325", "T_ah = 1"):
            assert f"\n{row}\n" in block, (fmu, row, block)
