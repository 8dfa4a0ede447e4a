"""What a first user trips over (issue "Usable beyond the repository") and the CLI's last ways to lose
a result (the reliability issue, items 5-7), each held by a test:

- global options in any position; a --fmu-dir that does not exist is named as such;
- a parameter inside its range that the FMU refuses at initialization (inconsistent with others):
  exit 2 with the FMU's own reason, one error line, the previous result untouched;
- a push force outside the plant's declared range: exit 2 before anything runs, the previous
  result untouched, no NumPy warnings;
- an FMU that cannot be loaded (wrong GUID, no linux64 binary, a corrupt library): exit 2, the
  output folder untouched;
- range errors give the unit; a scenario-name typo gets "did you mean";
- `anklehip list` has a header and lines that fit the terminal;
- every command that writes defaults to a results folder (export, record) and takes --out;
- a Scenario object refuses a field it does not have (a guessed attribute is an error, not a
  silent no-op) and PushProfile.scaled_to scales the push.
"""
from __future__ import annotations

import json
import re
import shutil
import zipfile
from pathlib import Path

import numpy as np

import pytest

from anklehip.cli import main
from test_hostile_input import one_error_line, snapshot


@pytest.fixture
def previous(tmp_path, fmu_dir):
    """A folder holding the complete result of an earlier run of ankle_small_push."""
    out = tmp_path / "out"
    assert main(["--fmu-dir", str(fmu_dir), "run", "ankle_small_push", "--out", str(out), "--stop-time", "0.5",
                 "--no-progress"]) == 0
    return out


def _untouched(folder: Path, before: dict[str, bytes]) -> None:
    assert snapshot(folder) == before
    assert not list(folder.glob("*.incomplete.csv")) and not list(folder.glob(".*.tmp"))


# ----------------------------------------------------------------------------------------------
# global options

@pytest.mark.parametrize("where", ["before", "after"])
def test_global_options_in_any_position(where, fmu_dir, tmp_path, capsys):
    args = ["run", "ankle_small_push", "--out", str(tmp_path / "o"), "--stop-time", "0.1", "--no-progress"]
    argv = ["--fmu-dir", str(fmu_dir), *args] if where == "before" else [*args, "--fmu-dir", str(fmu_dir)]
    assert main(argv) == 0
    assert (tmp_path / "o" / "ankle_small_push.csv").is_file()
    capsys.readouterr()
    # and the command's value is the one used: a folder without FMUs after the command fails
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["--fmu-dir", str(fmu_dir), *args[:-3], "--fmu-dir", str(empty)]) == 2
    one_error_line(capsys.readouterr().err, "AnkleHipController.fmu not found in", str(empty))


@pytest.mark.parametrize("argv", [["run", "chest_push"], ["info", "AnkleHipController"], ["where"],
                                  ["steptest", "ankle_small_push"]])
def test_a_missing_fmu_dir_is_named_as_such(argv, tmp_path, capsys):
    missing = tmp_path / "nowhere"
    assert main([*argv, "--fmu-dir", str(missing)]) == 2 or argv == ["where"]
    err = capsys.readouterr().err
    if argv != ["where"]:
        one_error_line(err, f"--fmu-dir {missing}: no such folder")


# ----------------------------------------------------------------------------------------------
# inputs refused before anything is written

def test_parameter_refused_at_initialization_exits_2_with_the_fmus_reason(previous, capsys):
    """zmp_limit_front = 0.45 is inside its declared range but beyond the toe: the controller FMU
    refuses it in fmi2ExitInitializationMode. Before: exit 1, "FMICallException ... status 3", a
    one-row .incomplete.csv, the previous complete CSV deleted."""
    before = snapshot(previous)
    assert main(["run", "ankle_small_push", "--out", str(previous), "--set", "controller.zmp_limit_front=0.45"]) == 2
    cap = capsys.readouterr()
    line = one_error_line(cap.err, "AnkleHipController.fmu refused its parameters at initialization",
                          "zmp_limit_front = 0.45 lies outside the foot")
    assert "FMICallException" not in line and "see the messages above" not in line
    assert "[ERROR]" not in cap.out
    _untouched(previous, before)


@pytest.mark.parametrize("force", ["1e308", "-1e6", "1000.5"])
def test_push_force_outside_the_plants_range_exits_2_before_the_run(force, previous, tmp_path, capsys):
    before = snapshot(previous)
    sc = tmp_path / "strong.toml"
    sc.write_text(f'name = "strong"\nstop_time = 1.0\n[[push]]\nkind = "pulse"\nt = 0.2\nduration = 0.1\n'
                  f"force = {force}\n")
    with _no_warnings():
        assert main(["run", str(sc), "--out", str(previous)]) == 2
    line = one_error_line(capsys.readouterr().err, "strong.toml: push:", "Hoap2Plant.fmu's input push_force",
                          "[-1000, 1000] N")
    assert f"{float(force):g} N" in line
    _untouched(previous, before)
    assert not (previous / "strong.csv").exists()


def test_sweep_force_outside_the_plants_range_exits_2(tmp_path, capsys):
    out = tmp_path / "sw"
    assert main(["sweep", "hip_saves_push", "--forces", "5,2000", "--out", str(out), "--workers", "1"]) == 2
    one_error_line(capsys.readouterr().err, "--forces: a peak push of 2000 N", "[-1000, 1000] N")
    assert not out.exists()


class _no_warnings:
    """No Python warning (e.g. NumPy's RuntimeWarning on an overflow) is issued in the block."""

    def __enter__(self):
        import warnings
        self._cm = warnings.catch_warnings(record=True)
        self._log = self._cm.__enter__()
        warnings.simplefilter("always")

    def __exit__(self, *exc):
        self._cm.__exit__(*exc)
        assert not self._log, [str(w.message) for w in self._log]


def _tampered(fmu_dir: Path, tmp_path: Path, how: str) -> Path:
    """A copy of the FMU folder whose controller FMU is broken in one way."""
    d = tmp_path / f"fmus_{how}"
    shutil.copytree(fmu_dir, d)
    src = fmu_dir / "AnkleHipController.fmu"
    dst = d / "AnkleHipController.fmu"
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if how == "guid" and item.filename == "modelDescription.xml":
                data = data.replace(b'guid="', b'guid="x', 1)
            if how == "no_linux64" and item.filename.startswith("binaries/linux64/"):
                continue
            if how == "corrupt_so" and item.filename.endswith(".so"):
                data = b"\x7fELF" + b"\0" * 200
            zout.writestr(item, data)
    return d


@pytest.mark.parametrize("how, needle", [("guid", "fmi2Instantiate failed"),
                                         ("no_linux64", "its binary cannot be loaded"),
                                         ("corrupt_so", "its binary cannot be loaded")])
@pytest.mark.parametrize("engine", ["fmpy", "native"])
def test_unloadable_fmu_exits_2_and_leaves_the_folder_alone(how, needle, engine, previous, fmu_dir, tmp_path,
                                                           capsys):
    before = snapshot(previous)
    bad = _tampered(fmu_dir, tmp_path, how)
    assert main(["run", "ankle_small_push", "--out", str(previous), "--fmu-dir", str(bad), "--engine", engine,
                 "--stop-time", "0.5"]) == 2
    one_error_line(capsys.readouterr().err, "AnkleHipController.fmu", needle)
    _untouched(previous, before)
    # a new folder is not even created
    fresh = tmp_path / "fresh"
    assert main(["run", "ankle_small_push", "--out", str(fresh), "--fmu-dir", str(bad), "--engine", engine]) == 2
    assert not fresh.exists()


def test_range_error_gives_the_unit(capsys):
    assert main(["run", "chest_push", "--set", "plant.theta_hip_init=10"]) == 2
    one_error_line(capsys.readouterr().err, "'theta_hip_init' = 10 is outside its range [-1.23918, 1.43117] rad",
                   "--set plant.theta_hip_init")


@pytest.mark.parametrize("argv, needles", [
    (["run", "chest_pus"], ["no scenario named 'chest_pus'", "did you mean chest_push"]),
    (["run", "paper_five_push"], ["did you mean paper_five_pushes"]),
    (["sweep", "force_duraton"], ["no sweep file named 'force_duraton'", "did you mean force_duration"]),
    (["steptest", "chest_push_hip_cycl"], ["did you mean chest_push_hip_cycle"]),
    (["regen-references", "chest_pus", "--check"], ["unknown scenario(s): chest_pus", "did you mean chest_push"]),
])
def test_name_typos_get_did_you_mean(argv, needles, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    line = [ln for ln in err.splitlines() if "error" in ln][0]
    for n in needles:
        assert n in line, line


# ----------------------------------------------------------------------------------------------
# list, where, defaults

def test_list_has_a_header_and_fits_the_terminal(monkeypatch, capsys):
    from anklehip.files.paths import scenarios_dir
    monkeypatch.setenv("COLUMNS", "100")
    assert main(["list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[:5] == ["scenario", "plant", "stop", "peak", "push"]
    assert max(len(ln) for ln in lines[:-1]) <= 100, max(lines, key=len)
    names = sorted(p.stem for p in scenarios_dir().glob("*.toml"))
    assert [ln.split()[0] for ln in lines[1:-1]] == names
    assert lines[-1].startswith(f"{len(names)} scenarios in ")
    row = next(ln for ln in lines if ln.startswith("paper_five_pushes "))
    assert "sagittal" in row and "60 s" in row and "+6.1 N" in row and "stand, phases 0123" in row


def test_where_names_the_checkout_and_the_build(fmu_dir, capsys):
    from conftest import REPO_ROOT
    assert main(["where"]) == 0
    out = capsys.readouterr().out
    assert re.search(rf"^checkout +{re.escape(str(REPO_ROOT))}$", out, re.M), out
    for name in ("AnkleHipController", "AnkleHipController3D", "Hoap2Plant", "Hoap2Plant3D"):
        assert re.search(rf"^{name}\.fmu +{re.escape(str(fmu_dir / (name + '.fmu')))}$", out, re.M), out


def test_export_and_record_default_to_a_results_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["export", "ssp", "ankle_small_push"]) == 0
    assert (tmp_path / "results" / "ankle_small_push" / "ankle_small_push.ssp").is_file()
    assert main(["record", "ankle_small_push", "--stop-time", "0.2", "--no-progress"]) == 0
    assert (tmp_path / "results" / "steptests" / "ankle_small_push" / "AnkleHipController_in.csv").is_file()
    assert main(["record", "ankle_small_push", "--stop-time", "0.2", "--out", "elsewhere", "--no-progress"]) == 0
    assert (tmp_path / "elsewhere" / "steptest.toml").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["elsewhere", "results"]


# ----------------------------------------------------------------------------------------------
# the API's objects

def test_scenario_refuses_unknown_fields_and_scales_its_push():
    import anklehip
    sc = anklehip.load_scenario("hip_saves_push")
    with pytest.raises(AttributeError):
        sc.pushes = None            # a guess: an error, not a field nobody reads
    with pytest.raises(AttributeError):
        sc.push.scaled_by = 2.0
    p = sc.push.scaled_to(10.0)
    assert p.peak() == pytest.approx(10.0) and sc.push.peak() == pytest.approx(9.5)
    assert np.allclose(p.values, sc.push.values * 10.0 / 9.5)
    with pytest.raises(ValueError, match="no force to scale"):
        anklehip.PushProfile.zero().scaled_to(5.0)


def test_summary_json_of_a_run_through_the_api(tmp_path):
    import anklehip
    r = anklehip.run("ankle_small_push", out=tmp_path, stop_time=0.5)
    assert r.files["csv"] == tmp_path / "ankle_small_push.csv"
    s = json.loads((tmp_path / "ankle_small_push.summary.json").read_text())
    assert s["shortened_from_stop_time"] == 6.0 and s["end_time"] == pytest.approx(0.5)
    assert r.notes and "replaces the scenario's 6 s" in r.notes[0]
