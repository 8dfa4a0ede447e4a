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
    from anklehip.analysis.summary import count_cycles
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


# ---------------------------------------------------------------------------------------------
# every option documented

def _walk(parser, prog="anklehip"):
    """(command, action) for every argument of the parser and its subcommands, -h/--help excepted."""
    import argparse
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        yield prog, action
        if isinstance(action, argparse._SubParsersAction):
            for choice in action._choices_actions:        # the command list of `anklehip --help`
                yield f"{prog} (command list)", choice
            for name, sub in action.choices.items():
                yield from _walk(sub, f"{prog} {name}")


def test_every_option_of_every_command_has_help():
    """Establishes: `anklehip [COMMAND] --help` explains every argument (no option shows up bare)."""
    from anklehip.cli import build_parser
    actions = list(_walk(build_parser()))
    assert len(actions) > 80
    bare = [f"{prog}: {'/'.join(a.option_strings) or a.dest}" for prog, a in actions
            if not (a.help or "").strip() or a.help == "==SUPPRESS=="]
    assert not bare, "arguments without help: " + ", ".join(bare)
    # an option with a default says which
    quiet = [f"{prog}: {'/'.join(a.option_strings) or a.dest}" for prog, a in actions
             if a.default not in (None, False) and a.nargs != 0 and "default" not in a.help]
    assert not quiet, "defaults not stated: " + ", ".join(quiet)
    # progress bars can be turned off wherever a command draws them
    subs = next(a for _, a in actions if a.dest == "cmd").choices
    for cmd in ("run", "plot", "record", "soak", "regen-references"):
        assert any("--no-progress" in a.option_strings for a in subs[cmd]._actions), cmd


def test_plot_no_progress_reaches_the_figures(tmp_path, monkeypatch):
    import anklehip.running.run as run
    seen = []
    monkeypatch.setattr(run, "make_figures", lambda *a, **k: seen.append(k.get("progress")) or [])
    csv = tmp_path / "syn.csv"
    write_csv(csv, synthetic_result(t_end=0.5))
    assert main(["plot", str(csv), "--no-progress"]) == 0
    assert main(["plot", str(csv)]) == 0
    assert seen == [False, None]        # like run: off, or a bar only on a terminal


# ---------------------------------------------------------------------------------------------
# anklehip info

INFO_COLUMNS = ["name", "type", "unit (display)", "start", "min", "max", "variability", "description"]


def _rows(text, title):
    """The table rows of `title` (e.g. "Parameters") in `anklehip info` text: name -> the cells
    of INFO_COLUMNS (cut at the header's column positions)."""
    lines = text.splitlines()
    i = next(k for k, ln in enumerate(lines) if ln.startswith(title + " ("))
    head = lines[i + 1]
    at = [head.index(c) for c in INFO_COLUMNS] + [None]
    rows = {}
    for ln in lines[i + 2:]:
        if not ln.strip():
            break
        if ln.startswith("      items"):
            continue
        cells = [ln[a:b].strip() for a, b in zip(at, at[1:])]
        rows[cells[0]] = cells
    return rows


def test_info_controller_parameters_with_unit_default_and_range(controller_fmu, capsys):
    """Establishes: `anklehip info AnkleHipController` (a bare model name, found like the package's
    FMUs) shows the identity a user needs and every parameter with its unit, start value and range
    as the modelDescription states them; --json has the same parameters and values."""
    import json
    import zipfile

    from fmpy import read_model_description

    from anklehip.running.fmu import FMUInfo
    md = read_model_description(str(controller_fmu))
    params = FMUInfo.load(controller_fmu).parameters()
    assert main(["--fmu-dir", str(controller_fmu.parent), "info", "AnkleHipController"]) == 0
    text = capsys.readouterr().out
    with zipfile.ZipFile(controller_fmu) as z:     # the build's platforms: linux64, + win64, aarch64-linux
        built = sorted({n.split("/")[1] for n in z.namelist() if n.startswith("binaries/") and n.count("/") >= 2
                        and not n.endswith("/")})
    assert "linux64" in built
    for needle in (f"model name          {md.modelName}", f"FMI version         {md.fmiVersion}", md.guid,
                   md.generationTool, md.generationDateAndTime, f"platforms           {', '.join(built)}", md.license,
                   "default experiment  start 0 s, stop", "logEvents"):
        assert needle in text, needle
    rows = _rows(text, "Parameters")
    assert set(rows) == set(params)
    for name, v in params.items():
        cells = rows[name]
        assert cells[1] == v.type and cells[6] == v.variability, name
        assert cells[2].split()[0] == (v.unit or "-"), name
        assert float(cells[3]) == v.start, name
        assert [float(x) if x != "-" else None for x in cells[4:6]] == [v.min, v.max], name
    # e.g. Ka  Real  N.m/rad  40  0.001  1000000  tunable  Ankle virtual stiffness (eq. 11; ...)
    ka = rows["Ka"]
    assert ka[1:3] == ["Real", "N.m/rad"] and ka[7].startswith("Ankle virtual stiffness")
    assert [float(x) for x in ka[3:6]] == [params["Ka"].start, params["Ka"].min, params["Ka"].max]

    assert main(["info", str(controller_fmu), "--json"]) == 0
    js = json.loads(capsys.readouterr().out)
    assert js["model_name"] == md.modelName and js["guid"] == md.guid and "linux64" in js["platforms"]
    jp = {v["name"]: v for v in js["variables"]["parameter"]}
    assert set(jp) == set(params)
    for name, v in params.items():
        assert (jp[name]["type"], jp[name]["unit"], jp[name]["start"], jp[name]["min"], jp[name]["max"]) == \
            (v.type, v.unit, v.start, v.min, v.max), name
    assert [c["name"] for c in js["log_categories"]] == [c.name for c in md.logCategories]
    assert js["default_experiment"]["step_size"] == float(md.defaultExperiment.stepSize)


def test_info_shows_the_integer_or_enumeration_outputs(controller_fmu, capsys):
    """The controller's phase output (Integer, or an Enumeration with its items) is listed with the
    other outputs; --causality and --name select."""
    import json
    assert main(["info", str(controller_fmu), "--causality", "output"]) == 0
    text = capsys.readouterr().out
    assert "Parameters (" not in text and "Inputs (" not in text and "not shown:" in text
    rows = _rows(text, "Outputs")
    assert rows["phase"][1] in ("Integer", "Enumeration") and "theta_ankle_ref" in rows
    assert rows["fault"][1] == "Integer"
    if rows["phase"][1] == "Enumeration":
        assert "items" in text.split("  phase ", 1)[1].splitlines()[1]
    assert main(["info", str(controller_fmu), "--json", "--causality", "output", "--name", "PHA"]) == 0
    js = json.loads(capsys.readouterr().out)
    assert list(js["variables"]) == ["output"] and [v["name"] for v in js["variables"]["output"]] == ["phase"]
    assert main(["info", str(controller_fmu), "--json", "--name", "zmp_limit_*", "--name", "Theta_H"]) == 0
    js = json.loads(capsys.readouterr().out)       # a glob over the whole name, or a substring
    assert sorted(v["name"] for v in js["variables"]["parameter"]) == ["zmp_limit_back", "zmp_limit_front"]
    assert [v["name"] for v in js["variables"]["input"]] == ["theta_hip"]
    assert [v["name"] for v in js["variables"]["output"]] == ["theta_hip_ref", "dtheta_hip_ref"]


ENUM_MD = """<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="Enums" guid="{00000000-0000-0000-0000-000000000001}"
  generationTool="hand" generationDateAndTime="2020-01-01T00:00:00Z" license="MIT">
  <CoSimulation modelIdentifier="Enums" canHandleVariableCommunicationStepSize="true"/>
  <UnitDefinitions><Unit name="m"><BaseUnit m="1"/><DisplayUnit name="mm" factor="1000"/></Unit></UnitDefinitions>
  <TypeDefinitions>
    <SimpleType name="Mode"><Enumeration><Item name="off" value="1"/><Item name="on" value="2"/></Enumeration></SimpleType>
    <SimpleType name="Length"><Real unit="m" displayUnit="mm" min="0" max="2"/></SimpleType>
  </TypeDefinitions>
  <DefaultExperiment startTime="0" stopTime="2" stepSize="0.01" tolerance="1e-06"/>
  <ModelVariables>
    <ScalarVariable name="mode" valueReference="1" causality="parameter" variability="fixed" description="Mode">
      <Enumeration declaredType="Mode" start="2"/></ScalarVariable>
    <ScalarVariable name="length" valueReference="2" causality="parameter" variability="tunable">
      <Real declaredType="Length" start="0.5"/></ScalarVariable>
    <ScalarVariable name="state" valueReference="3" causality="output" variability="discrete">
      <Enumeration declaredType="Mode"/></ScalarVariable>
    <ScalarVariable name="secret" valueReference="4" causality="local" variability="discrete"><Integer/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="3"/></Outputs></ModelStructure>
</fmiModelDescription>
"""


def test_info_enumeration_items_and_declared_types(tmp_path, capsys):
    """An Enumeration shows its items (value=name) and its start by name; a Real's unit, display
    unit and range come from its declared type; locals are counted, shown on request."""
    import json
    import zipfile
    fmu = tmp_path / "Enums.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        z.writestr("modelDescription.xml", ENUM_MD)
        z.writestr("binaries/win64/Enums.dll", "")
    assert main(["info", str(fmu)]) == 0
    text = capsys.readouterr().out
    assert "platforms           win64" in text and "tolerance 1e-06" in text and "1 m = 1000 mm" in text
    p = _rows(text, "Parameters")
    assert p["mode"][1:8] == ["Enumeration", "-", "2 (on)", "-", "-", "fixed", "Mode"]
    assert p["length"][1:7] == ["Real", "m (mm)", "0.5", "0", "2", "tunable"]
    assert "items (type Mode): 1=off, 2=on" in text
    assert _rows(text, "Outputs")["state"][1] == "Enumeration"
    assert "not shown: 1 local variable" in text and "secret" not in text
    assert main(["info", str(fmu), "--json", "--causality", "local"]) == 0
    js = json.loads(capsys.readouterr().out)
    assert [v["name"] for v in js["variables"]["local"]] == ["secret"]
    assert main(["info", str(fmu), "--json"]) == 0
    js = json.loads(capsys.readouterr().out)
    mode = js["variables"]["parameter"][0]
    assert mode["start"] == 2 and mode["items"] == [{"value": 1, "name": "off", "description": None},
                                                    {"value": 2, "name": "on", "description": None}]
    assert js["variables"]["parameter"][1]["display_unit"] == "mm"


def test_info_bad_files_exit_2_naming_the_file(tmp_path, monkeypatch, capsys):
    import zipfile
    monkeypatch.setenv("ANKLEHIP_FMU_DIR", str(tmp_path))
    not_zip = tmp_path / "text.fmu"
    not_zip.write_text("not an FMU\n")
    no_md = tmp_path / "nomd.fmu"
    with zipfile.ZipFile(no_md, "w") as z:
        z.writestr("binaries/linux64/x.so", "")
    bad_xml = tmp_path / "badxml.fmu"
    with zipfile.ZipFile(bad_xml, "w") as z:
        z.writestr("modelDescription.xml", "<fmiModelDescription")
    for arg, why in ((str(tmp_path / "missing.fmu"), "no such file"), (str(not_zip), "not a ZIP archive"),
                     (str(no_md), "no modelDescription.xml"), (str(bad_xml), "modelDescription.xml: "),
                     ("NoSuchModel", "no NoSuchModel.fmu in")):
        assert main(["info", arg]) == 2, arg
        err = capsys.readouterr().err
        assert err.startswith(f"anklehip: error: {arg}: ") and why in err and "Traceback" not in err, err
        assert len(err.strip().splitlines()) == 1
