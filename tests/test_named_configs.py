"""Named controller configurations ("default", "paper"): generated into the controller FMU from the C
library (resources/configurations.toml), selected by name in a scenario (`controller_config`), on
the command line (`--controller-config`) and in sweep variants (`config=`), with clear errors for
unknown names. Establishes that the paper's configuration is one name away for every user and that
the values a run uses are the C library's (one source of truth)."""
import json
import tomllib

import pytest

from anklehip.cli import main
from anklehip.running.fmu import FMUError, FMUInfo
from anklehip.running.master import Models, simulate
from anklehip.files.scenario import ScenarioError, parse_scenario
from anklehip.running.sweep import parse_variant


def test_fmu_ships_the_c_librarys_configurations(controller_unzipped, controller_fmu):
    text = (controller_unzipped / "resources" / "configurations.toml").read_text()
    confs = tomllib.loads(text)
    assert list(confs)[:2] == ["default", "paper"]
    assert set(confs["default"]) == {"description"}          # the defaults differ from nothing
    paper = confs["paper"]
    # the paper's numbers (Nenchev & Nishio 2010): trigger at 45 mm, 1 s transition
    assert paper["zmp_limit_front"] == 0.045 and paper["T_ah"] == 1.0
    info = FMUInfo.load(controller_fmu)
    params = info.parameters()
    for k, v in paper.items():
        if k != "description":
            assert k in params, f"configuration value {k} is not a parameter"
            assert v != params[k].start, f"{k} equals the default and should not be listed"
    assert info.configuration("paper") == {k: v for k, v in paper.items() if k != "description"}
    with pytest.raises(FMUError, match=r"no configuration 'Paper' \(here\); known: default, paper"):
        info.configuration("Paper", "here")


def test_scenario_key_and_precedence(fmu_dir):
    sc = parse_scenario({"stop_time": 0.05, "controller_config": "paper", "controller": {"T_ah": 0.7}}, "t.toml")
    assert sc.controller_config == "paper"
    res = simulate(sc, Models.load(fmu_dir), controller_overrides={"Kpr": 90.0}, progress=False)
    p = res.controller_parameters
    # configuration < scenario [controller] < caller
    assert p["zmp_limit_front"] == 0.045 and p["T_ah"] == 0.7 and p["Kpr"] == 90.0
    assert res.controller_config == "paper"
    with pytest.raises(ScenarioError, match="t.toml: controller_config: must be a string"):
        parse_scenario({"stop_time": 1.0, "controller_config": 1}, "t.toml")
    with pytest.raises(FMUError, match="no configuration 'nope'"):
        simulate(parse_scenario({"stop_time": 0.01, "controller_config": "nope"}, "t.toml"),
                 Models.load(fmu_dir), progress=False)


def test_cli_run_with_paper_config(tmp_path, fmu_dir, capsys):
    out = tmp_path / "o"
    rc = main(["--fmu-dir", str(fmu_dir), "run", "ankle_small_push", "--controller-config", "paper",
               "--out", str(out), "--no-progress"])
    cap = capsys.readouterr()
    assert rc == 0, cap.out + cap.err
    assert "not compared with" in cap.err          # the reference belongs to the default configuration
    s = json.loads((out / "ankle_small_push.summary.json").read_text())
    assert s["controller_config"] == "paper" and s["comparison"] is None
    assert main(["--fmu-dir", str(fmu_dir), "run", "ankle_small_push", "--controller-config", "nope"]) == 2
    assert "has no configuration 'nope' (--controller-config); known: default, paper" in capsys.readouterr().err


def test_sweep_variant_config_and_bad_variants(fmu_dir, capsys):
    v = parse_variant("p:config=paper,controller.Ka=30")
    assert (v.name, v.config, v.controller) == ("p", "paper", {"Ka": 30})
    with pytest.raises(ScenarioError, match="at most one non-empty config=NAME"):
        parse_variant("p:config=")
    for spec, msg in [("x:controller.nosuch=1", "has no parameter 'nosuch' (--variant x [controller])"),
                      ("y:config=papr", "has no configuration 'papr' (--variant y)")]:
        assert main(["--fmu-dir", str(fmu_dir), "sweep", "ankle_small_push", "--forces", "1", "--variant", spec]) == 2
        assert msg in capsys.readouterr().err


def test_3d_fmu_ships_the_stepping_configuration(fmu_dir):
    """AnkleHipController3D.fmu lists the C library's stepping configuration lasting_push
    (ahc_step_params_named; docs/controller.md §12.6) after the shared ones: the stepping layer on and
    only values that differ from the defaults; the sagittal FMU, which has no stepping layer, does not."""
    m3 = Models.load(fmu_dir, plant_model="3d", controller_model="3d")
    confs = m3.controller.configurations()
    assert list(confs)[:3] == ["default", "paper", "omnidirectional"] and list(confs)[-1] == "lasting_push"
    named = m3.controller.configuration("lasting_push")
    params = m3.controller.parameters()
    assert named["stepping_enabled"] == 1 and named["step_push_estimate"] == 2 and named["step_close"] == 0
    assert all(k.startswith("step") and v != params[k].start for k, v in named.items())
    assert "lasting_push" not in Models.load(fmu_dir).controller.configurations()
