"""The `anklehip` command line: commands that need no FMU, and the errors when one is missing."""
import numpy as np
import pytest
from fmpy.util import write_csv

from anklehip.cli import main


def synthetic_result(t_end=3.0, h=0.01):
    t = np.arange(0, t_end + h / 2, h)
    dt = [("time", float), ("theta_ankle", float), ("theta_hip", float), ("zmp_x", float), ("fz", float),
          ("com_x", float), ("com_z", float), ("foot_pitch", float), ("theta_ankle_ref", float),
          ("theta_hip_ref", float), ("push_force", float), ("contact_mode", np.int32), ("fallen", np.int32),
          ("phase", np.int32)]
    d = np.zeros(len(t), dt)
    d["time"] = t
    bump = np.exp(-((t - 1.5) / 0.4) ** 2)
    d["theta_ankle"] = 0.05 * bump
    d["theta_hip"] = -0.2 * bump
    d["theta_ankle_ref"], d["theta_hip_ref"] = d["theta_ankle"], d["theta_hip"]
    d["zmp_x"] = 0.04 * bump
    d["com_x"] = 0.012 * bump
    d["com_z"] = 0.255
    d["fz"] = 70.2
    d["push_force"] = np.where((t > 1.0) & (t < 1.6), 8.0, 0.0)
    d["phase"] = np.select([t < 1.2, t < 1.6, t < 2.2, t < 2.6], [0, 1, 2, 3], 0)
    return d


def test_help_and_list(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--help"])
    assert e.value.code == 0
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    assert "paper_five_pushes" in out and "hip_disabled_falls" in out


def test_version_is_the_packages_and_python_m_works(capsys):
    """Establishes: `anklehip --version` prints the version pyproject.toml declares (the two
    sources cannot drift), and `python -m anklehip` is the same command (docs/fmu.md §5)."""
    import subprocess
    import sys
    import tomllib
    from pathlib import Path
    import anklehip
    declared = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())["project"]["version"]
    assert anklehip.__version__ == declared
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    assert capsys.readouterr().out.strip() == f"anklehip {declared}"
    r = subprocess.run([sys.executable, "-m", "anklehip", "--version"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and r.stdout.strip() == f"anklehip {declared}", r.stderr


def test_run_without_fmus_names_the_file_and_the_fix(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("ANKLEHIP_FMU_DIR", str(tmp_path))
    assert main(["run", "ankle_small_push", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "AnkleHipController.fmu not found in" in err and "bash scripts/setup.sh" in err
    assert not (tmp_path / "o").exists()


def test_run_bad_scenario(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text("stop_time = 1\n[[push]]\nkind = 'pulse'\nforce = 1\nduration = -1\n")
    assert main(["run", str(bad)]) == 2
    assert "bad.toml: push[0].duration: must be > 0, got -1" in capsys.readouterr().err
    assert main(["run", "no_such_scenario"]) == 2
    assert "no scenario named 'no_such_scenario'" in capsys.readouterr().err


def test_run_bad_set(capsys):
    assert main(["run", "ankle_small_push", "--set", "Ka=3"]) == 2
    assert "expected controller.NAME=VALUE" in capsys.readouterr().err


def test_plot_and_animate_synthetic(tmp_path):
    csv = tmp_path / "syn.csv"
    write_csv(csv, synthetic_result())
    assert main(["plot", str(csv), "--out", str(tmp_path / "fig"), "--animate", "--fps", "5",
                 "--anim-start", "1.0", "--anim-stop", "2.0"]) == 0
    for name in ("syn_overview.png", "syn_fig4_joint_angles.png", "syn_fig5_first_cycle.png", "syn.gif"):
        assert (tmp_path / "fig" / name).stat().st_size > 1000, name


def test_plot_generic_csv(tmp_path):
    csv = tmp_path / "g.csv"
    t = np.linspace(0, 1, 11)
    d = np.zeros(len(t), [("time", float), ("a", float), ("b", float)])
    d["time"], d["a"], d["b"] = t, t ** 2, -t
    write_csv(csv, d)
    assert main(["plot", str(csv)]) == 0
    assert (tmp_path / "g_overview.png").is_file()


def test_summary_helpers():
    from anklehip.results import count_cycles
    assert count_cycles(np.array([0, 0, 1, 2, 3, 0, 0, 1, 2, 3, 0])) == 2
    assert count_cycles(np.array([0, 1, 2, 3])) == 0
    assert count_cycles(np.array([0, 1, 0, 1, 2, 3, 0])) == 1
    assert count_cycles(np.array([0, 1, 2, 3, 2, 3, 0, 1, 2, 0])) == 1
    assert count_cycles(np.array([1, 2, 3, 0])) == 0          # did not start from phase 0


def test_3d_run_draws_the_frontal_plane(tmp_path):
    """A 3D result gets the frontal-plane figure and a two-view animation (side and from behind)."""
    from PIL import Image
    out = tmp_path / "o"
    assert main(["run", "side_push_3d", "--out", str(out), "--plots", "--animate", "--fps", "4"]) == 0
    assert (out / "side_push_3d_frontal.png").stat().st_size > 1000
    with Image.open(out / "side_push_3d.gif") as im:
        assert im.n_frames >= 5 and im.width > 1.5 * im.height   # two panels side by side
