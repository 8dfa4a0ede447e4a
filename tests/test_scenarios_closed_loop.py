"""Every scenario in scenarios/: closed-loop run of both FMUs, expected outcome, reference tube.

Regenerate the references deliberately with `anklehip regen-references` (docs/scenarios.md).
"""
import json

import numpy as np
import pytest

from anklehip.cli import main
from anklehip.running.run import compare_with_reference
from anklehip.running.master import Models, simulate
from anklehip.files.paths import scenarios_dir
from anklehip.analysis.summary import check_expect
from anklehip.files.scenario import load_scenario

SCENARIOS = sorted(p.stem for p in scenarios_dir().glob("*.toml"))


@pytest.fixture(scope="module")
def models():
    return Models.load()      # $ANKLEHIP_FMU_DIR or <repo>/build/fmus, clear error if missing


@pytest.mark.parametrize("name", SCENARIOS)
def test_scenario(models, name):
    sc = load_scenario(scenarios_dir() / f"{name}.toml")
    if (sc.plant_model, sc.controller_model) != ("sagittal", "sagittal"):
        models = Models.for_scenario(sc)
    res = simulate(sc, models, progress=False)
    assert res.outcome in ("completed", "fell"), res.message
    failed = [f"{c.name}: {c.detail}" for c in check_expect(res, sc.expect) if not c.ok]
    assert not failed, f"{name}: expected outcome not met: " + "; ".join(failed)
    if sc.reference is not None:
        assert sc.reference.file.is_file(), (f"{sc.reference.file} missing; create it with "
                                             f"`anklehip regen-references {name}`")
        rep = compare_with_reference(sc, res)
        assert rep.passed, rep.text(verbose=False)


def test_run_writes_csv_summary_and_marks_a_fall(models, tmp_path, capsys):
    """`anklehip run` on the falling scenario: the data up to the fall is kept in
    <name>.incomplete.csv, never in <name>.csv, and the summary says so."""
    out = tmp_path / "run"
    (out).mkdir()
    (out / "hip_disabled_falls.csv").write_text("stale")           # from an earlier run
    rc = main(["run", "hip_disabled_falls", "--out", str(out), "--no-progress", "--stop-time", "4"])
    assert rc == 0
    s = json.loads((out / "hip_disabled_falls.summary.json").read_text())
    assert s["outcome"] == "fell" and s["complete"] is False and s["fell_at"] > 1.0
    assert s["message"].startswith("fell at t=")
    assert not (out / "hip_disabled_falls.csv").exists()
    from fmpy.util import read_csv
    d = read_csv(out / "hip_disabled_falls.incomplete.csv")
    assert d["time"][-1] == pytest.approx(s["fell_at"]) and d["fallen"][-1] == 1
    assert "fell at t=" in capsys.readouterr().out


def test_unknown_parameter_override_names_fmu_and_parameter(models, capsys):
    assert main(["run", "ankle_small_push", "--set", "controller.Kx=3", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "AnkleHipController.fmu has no parameter 'Kx'" in err


def test_override_changes_the_run(models):
    sc = load_scenario(scenarios_dir() / "ankle_small_push.toml")
    a = simulate(sc, models, stop_time=2.0, progress=False)
    b = simulate(sc, models, stop_time=2.0, controller_overrides={"Ka": 25.0}, progress=False)
    assert a.complete and b.complete and len(a.data) == 2001
    assert np.max(np.abs(b.data["theta_ankle"])) > 1.05 * np.max(np.abs(a.data["theta_ankle"]))


def test_sweep_two_workers(models, tmp_path, capsys):
    rc = main(["sweep", "ankle_small_push", "--forces", "3,5", "--variant", "full",
               "--variant", "ankle_only:controller.hip_strategy_enabled=0", "--workers", "2",
               "--out", str(tmp_path)])
    assert rc == 0
    lines = (tmp_path / "sweep.csv").read_text().splitlines()
    assert lines[0].startswith("variant,peak_force,outcome") and len(lines) == 5
    assert (tmp_path / "sweep.png").is_file()
    assert "largest survived 5 N" in capsys.readouterr().out


def test_run_plots(models, tmp_path):
    assert main(["run", "ankle_small_push", "--out", str(tmp_path), "--plots", "--no-progress"]) == 0
    for suffix in ("_overview.png", "_fig4_joint_angles.png", "_fig5_first_cycle.png", ".csv", ".summary.json"):
        assert (tmp_path / f"ankle_small_push{suffix}").is_file(), suffix
    s = json.loads((tmp_path / "ankle_small_push.summary.json").read_text())
    assert s["complete"] and s["expectations_met"] and s["comparison"]["passed"]
    assert len(s["pushes"]) == 1 and s["pushes"][0]["phases"] == [0]


def test_override_types_are_checked(models):
    from anklehip.running.fmu import FMUError
    from anklehip.running.master import check_overrides
    with pytest.raises(FMUError, match="parameter 'hip_strategy_enabled' is Integer, got 0.5"):
        check_overrides(models, {"hip_strategy_enabled": 0.5}, {})
    with pytest.raises(FMUError, match="Hoap2Plant.fmu has no parameter 'Ka'"):
        check_overrides(models, {}, {"Ka": 3.0})
    with pytest.raises(FMUError, match="parameter 'Ka' is Real, got boolean True"):
        check_overrides(models, {"Ka": True}, {})
    check_overrides(models, {"hip_strategy_enabled": False, "Ka": 30}, {"h_push": 0.3})


def _plant_step_that_raises(monkeypatch, exc, at_step):
    """Make the plant's fmi2DoStep raise `exc` at its `at_step`-th call (a Ctrl-C or a crash mid-run)."""
    from anklehip.running import master
    from anklehip.running.fmu import Slave

    class S(Slave):
        def __init__(self, info, *a, **k):
            super().__init__(info, *a, **k)
            if info.name.startswith("Hoap2Plant"):
                real, n = self.do_step, [0]

                def do_step(c, t, h, flag):
                    n[0] += 1
                    if n[0] == at_step:
                        raise exc
                    return real(c, t, h, flag)
                self.do_step = do_step
    monkeypatch.setattr(master, "Slave", S)


@pytest.mark.parametrize("exc, outcome", [(KeyboardInterrupt(), "interrupted"), (RuntimeError("boom"), "error")])
def test_interrupted_or_failed_run_keeps_partial_data_marked_incomplete(models, monkeypatch, tmp_path, capsys,
                                                                        exc, outcome):
    _plant_step_that_raises(monkeypatch, exc, 1500)
    out = tmp_path / "o"
    out.mkdir()
    for stale in ("_reference_failed.png", "_fig5_first_cycle.png", ".csv"):   # from an earlier run
        (out / f"ankle_small_push{stale}").write_text("stale")
    assert main(["run", "ankle_small_push", "--out", str(out), "--no-progress"]) == 1
    assert not (out / "ankle_small_push.csv").exists()
    s = json.loads((out / "ankle_small_push.summary.json").read_text())
    assert s["outcome"] == outcome and s["complete"] is False and not s["expectations_met"]
    from fmpy.util import read_csv
    d = read_csv(out / "ankle_small_push.incomplete.csv")
    # rows 0..1498 are complete (the 1500th plant step, from t=1.499, never finished)
    assert len(d) == 1499 and d["time"][-1] == pytest.approx(1.498) and np.all(d["fz"] > 10)
    assert "data kept up to t=1.498 s" in capsys.readouterr().out
    assert s["comparison"] is None and not (out / "ankle_small_push_reference_failed.png").exists()
    assert not (out / "ankle_small_push_fig5_first_cycle.png").exists()


def test_unknown_parameter_in_scenario_file_names_file_and_parameter(models, tmp_path, capsys):
    f = tmp_path / "x.toml"
    f.write_text("stop_time = 0.5\n[controller]\nKx = 3.0\n")
    assert main(["run", str(f), "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "AnkleHipController.fmu has no parameter 'Kx'" in err and "x.toml [controller]" in err
    assert "--set" not in err


def test_missing_reference_file_is_reported_not_silently_skipped(models, tmp_path, capsys):
    f = tmp_path / "y.toml"
    f.write_text("stop_time = 0.2\n[reference]\nfile = 'reference/nope.csv'\n")
    # the results are written, but a broken reference set-up fails the run (exit 1)
    assert main(["run", str(f), "--out", str(tmp_path / "o"), "--no-progress"]) == 1
    cap = capsys.readouterr()
    assert "y.toml: reference.file:" in cap.err and "nope.csv does not exist" in cap.err
    assert "[WARN]" in cap.out
    s = json.loads((tmp_path / "o" / "y.summary.json").read_text())
    assert s["comparison"] is None and "nope.csv does not exist" in s["warnings"][0]


def test_reference_signal_override_with_a_typo_is_an_error(models, tmp_path, capsys):
    """[reference.signals.<typo>] must not be silently ignored (unknown keys are errors)."""
    import shutil
    (tmp_path / "reference").mkdir()
    shutil.copy(scenarios_dir() / "reference" / "short_impact.csv", tmp_path / "reference" / "z.csv")
    f = tmp_path / "z.toml"
    f.write_text("stop_time = 0.2\n[reference]\nfile = 'reference/z.csv'\n[reference.signals.fZ]\nband_floor = 0.5\n")
    assert main(["run", str(f), "--out", str(tmp_path / "o"), "--no-progress"]) == 1
    cap = capsys.readouterr()
    assert "z.toml: reference.signals.fZ: not a compared signal" in cap.err and "[WARN]" in cap.out


def test_reference_outside_the_band_fails_the_run_but_keeps_the_results(models, tmp_path, capsys):
    """A run that meets its expectations but leaves its reference's band exits 1, with the CSV and
    the summary written (nothing is lost, and the failure is not silent)."""
    from fmpy.util import read_csv, write_csv
    (tmp_path / "reference").mkdir()
    ref = read_csv(str(scenarios_dir() / "reference" / "short_impact.csv"))
    ref["theta_hip"] += 0.05                      # 50 mrad off everywhere: far outside the band
    write_csv(str(tmp_path / "reference" / "t.csv"), ref)
    f = tmp_path / "t.toml"
    f.write_text((scenarios_dir() / "short_impact.toml").read_text()
                 .replace("reference/short_impact.csv", "reference/t.csv"))
    out = tmp_path / "o"
    assert main(["run", str(f), "--out", str(out), "--no-progress"]) == 1
    assert (out / "t.csv").is_file()
    s = json.loads((out / "t.summary.json").read_text())
    assert s["comparison"]["passed"] is False
    assert s["comparison"]["signals"]["theta_hip"]["passed"] is False
