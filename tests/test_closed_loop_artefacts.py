"""The closed loop as one artefact (issue 11): the SSP file run by fmpy.ssp and the container FMU
run by FMPy's simulate_fmu, against our own master on the same scenario.

Tolerance, and why: both run the loop as a plain co-simulation master does (each FMU steps from
the values exchanged at the previous communication point; the SSP master also starts every
connection at 0), while our master steps the controller first and hands its new set points to the
plant in the same step. The plant thus follows each set point 1 ms later, and the controller sees
fz = 0 at its very first tick in the SSP run (one tick of the 'lifted' fault bit). The hip moves at
up to ~3 rad/s during a transition, so the joint angles differ by up to a few mrad while the
pushed robot moves (bound: 0.01 rad), the phase sequence is the same, each phase switch comes
within 20 ms of the master's, and the posture the robot settles in agrees to 1e-5 rad.
The scenario is `paper_configuration` (controller_config = "paper"), so that the parameter set
matters: with the default parameters the hip strategy starts at another time (checked).
"""
from __future__ import annotations

import zipfile

import numpy as np
import pytest

from conftest import REPO_ROOT

STOP = 7.0     # the first push (t = 2 s) through all four phases and back to the ankle strategy


@pytest.fixture(scope="module")
def scenario():
    from anklehip.files.scenario import load_scenario
    return load_scenario(REPO_ROOT / "scenarios" / "paper_configuration.toml")


@pytest.fixture(scope="module")
def models(fmu_dir):
    from anklehip.running.master import Models
    return Models.load(fmu_dir)


@pytest.fixture(scope="module")
def master_run(scenario, models):
    from anklehip.running.master import simulate
    res = simulate(scenario, models, stop_time=STOP)
    assert res.outcome == "completed"
    return res.data


def _switches(t, phase):
    i = np.flatnonzero(np.diff(phase) != 0) + 1
    return [int(p) for p in phase[i]], t[i]


def _compare(t, theta_ankle, theta_hip, phase, ref):
    """The other master's trajectory (times t) against ours, as the module docstring states."""
    assert np.allclose(t, ref["time"][:len(t)], rtol=0, atol=1e-9)
    for name, x in (("theta_ankle", theta_ankle), ("theta_hip", theta_hip)):
        err = np.max(np.abs(x - ref[name][:len(t)]))
        assert err <= 0.01, f"{name}: {err:.3g} rad from our master's"
        assert abs(x[-1] - ref[name][len(t) - 1]) <= 1e-5, f"{name}: settles elsewhere"
    seq, when = _switches(t, phase)
    seq_ref, when_ref = _switches(ref["time"], ref["phase"])
    assert seq == seq_ref and seq[:4] == [1, 2, 3, 0], (seq, seq_ref)
    assert np.max(np.abs(when - when_ref)) <= 0.020, (when, when_ref)
    return when


def test_ssp_is_valid_and_complete(scenario, models, tmp_path):
    from fmpy.ssp.ssd import read_ssd
    from anklehip.files.export import write_ssp

    ssp = write_ssp(tmp_path / "loop.ssp", scenario, models)
    with zipfile.ZipFile(ssp) as z:
        names = set(z.namelist())
    assert {"SystemStructure.ssd", "resources/parameters.ssv", "resources/AnkleHipController.fmu",
            "resources/Hoap2Plant.fmu"} <= names
    ssd = read_ssd(str(ssp), validate=True)          # the SSP 1.0 schema
    conns = {(c.startElement, c.startConnector, c.endElement, c.endConnector) for c in ssd.system.connections}
    for v in ("theta_ankle", "theta_hip", "zmp_x", "fz"):
        assert ("plant", v, "controller", v) in conns
    for v in ("theta_ankle_ref", "theta_hip_ref"):
        assert ("controller", v, "plant", v) in conns
    assert (None, "push_force", "plant", "push_force") in conns
    # the controller's phase is the FMU's Enumeration (issue 28), with its items, in both variants
    # the tools that read enumerations get (the libcosim variant leaves it out: libcosim aborts)
    import xml.etree.ElementTree as ET
    ns = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
          "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon"}
    root = ET.fromstring(zipfile.ZipFile(ssp).read("SystemStructure.ssd"))
    phase = root.find(".//ssd:Component[@name='controller']/ssd:Connectors/ssd:Connector[@name='phase']", ns)
    assert phase is not None and phase.find("ssc:Enumeration", ns).get("name") == "Phase"
    items = [(i.get("name"), int(i.get("value")))
             for i in root.findall("ssd:Enumerations/ssc:Enumeration[@name='Phase']/ssc:Item", ns)]
    assert items == [("ankle", 0), ("ankle_to_hip", 1), ("hip", 2), ("hip_to_ankle", 3)]
    lc = write_ssp(tmp_path / "lc.ssp", scenario, models, system_input=False)
    read_ssd(str(lc), validate=True)
    lc_root = ET.fromstring(zipfile.ZipFile(lc).read("SystemStructure.ssd"))
    assert lc_root.find(".//ssc:Enumeration", ns) is None and lc_root.find("ssd:Enumerations", ns) is None


def test_ssp_runs_in_fmpy_like_our_master(scenario, models, master_run, tmp_path):
    from fmpy.ssp.simulation import simulate_ssp
    from fmpy.ssp.ssd import read_ssv
    from anklehip.files.export import write_ssp

    ssp = write_ssp(tmp_path / "loop.ssp", scenario, models)
    params = read_ssv(str(ssp), resource="resources/parameters.ssv")
    assert {p.name for p in params.parameters} >= {"controller.zmp_limit_front", "controller.T_ah"}
    push = scenario.push

    def run(parameter_set):
        r = simulate_ssp(str(ssp), stop_time=STOP, step_size=scenario.step, parameter_set=parameter_set,
                         input={"push_force": lambda t: float(push.value(np.array([t]))[0])})
        # a row holds the values after the step from its time: shift to the master's rows
        return r["time"][:-1] + scenario.step, r

    t, r = run(params)
    n = len(t)
    # the documented one tick of the lifted fault (fz = 0 from the zero-started connection)
    assert r["controller.fault"][0] == 32 and not np.any(r["controller.fault"][1:n]), r["controller.fault"][:5]
    when = _compare(np.round(t, 9), r["plant.theta_ankle"][:n], r["plant.theta_hip"][:n],
                    r["controller.phase"][:n], master_run[1:])
    t0, r0 = run(None)           # defaults: the hip strategy starts elsewhere
    _, when0 = _switches(np.round(t0, 9), r0["controller.phase"][:n])
    assert abs(when0[0] - when[0]) > 0.05, "the parameter set makes no difference"


def test_container_fmu_runs_the_loop_like_our_master(scenario, models, master_run, tmp_path):
    import fmpy
    from fmpy.validation import validate_fmu
    from anklehip.files.export import write_container_fmu

    fmu = write_container_fmu(tmp_path / "AnkleHipBalance.fmu", scenario, models)
    assert validate_fmu(str(fmu)) == []
    md = fmpy.read_model_description(str(fmu))
    assert [v.name for v in md.modelVariables if v.causality == "input"] == ["push_force"]
    h = scenario.step
    t = np.arange(int(round(STOP / h)) + 1) * h
    inp = np.zeros(len(t), dtype=[("time", float), ("push_force", float)])
    inp["time"] = t
    inp["push_force"][:-1] = scenario.push.step_averages(0.0, h, len(t) - 1)
    inp["push_force"][-1] = inp["push_force"][-2]
    r = fmpy.simulate_fmu(str(fmu), stop_time=STOP, step_size=h, output_interval=h, input=inp,
                          output=["theta_ankle", "theta_hip", "phase", "fault", "controller.zmp_limit_front"])
    # the container reads the plant's initial outputs in initialization mode (issue 28): no lifted
    # fault at the start (docs/fmu.md section 2)
    assert not np.any(r["fault"]), r["fault"][:5]
    assert np.all(r["controller.zmp_limit_front"] == 0.045)     # the scenario's configuration inside
    _compare(np.round(r["time"], 9), r["theta_ankle"], r["theta_hip"], r["phase"], master_run)


def test_cli_exports_both_artefacts(fmu_dir, tmp_path):
    from anklehip.cli import main

    ssp, fmu = tmp_path / "p5.ssp", tmp_path / "p5.fmu"
    assert main(["--fmu-dir", str(fmu_dir), "export", "ssp", "paper_five_pushes", "--out", str(ssp)]) == 0
    assert main(["--fmu-dir", str(fmu_dir), "export", "container", "paper_five_pushes", "--out", str(fmu)]) == 0
    with zipfile.ZipFile(fmu) as z:
        platforms = {n.split("/")[1] for n in z.namelist() if n.startswith("binaries/") and n.count("/") >= 2}
        nested = {n.split("/")[3] for n in z.namelist() if n.startswith("resources/Hoap2Plant/binaries/")
                  and n.count("/") >= 4}
    assert "linux64" in platforms and platforms <= nested, (platforms, nested)
    assert zipfile.ZipFile(ssp).testzip() is None
    assert main(["--fmu-dir", str(fmu_dir), "export", "ssp", "no_such_scenario"]) != 0


def test_frontal_scenario_ssp_carries_its_pushes_and_parameters(fmu_dir, tmp_path, capsys):
    """A frontal scenario's SSP: both push inputs are system inputs (the CLI names both), and the
    scenario's frontal parameters are in its parameter set."""
    from anklehip.cli import main

    ssp = tmp_path / "d.ssp"
    assert main(["--fmu-dir", str(fmu_dir), "export", "ssp", "diagonal_push_frontal_hip", "--out", str(ssp)]) == 0
    assert "drive push_force and push_force_y (N)" in capsys.readouterr().out
    with zipfile.ZipFile(ssp) as z:
        ssd, ssv = z.read("SystemStructure.ssd").decode(), z.read("resources/parameters.ssv").decode()
    assert '<ssd:Connection startConnector="push_force_y" endElement="plant" endConnector="push_force_y"/>' in ssd
    assert '<ssv:Parameter name="controller.hip_strategy_enabled_y"><ssv:Integer value="1"/>' in ssv
    assert '<ssv:Parameter name="controller.zmp_limit_y"><ssv:Real value="0.03"/>' in ssv
