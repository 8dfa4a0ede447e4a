"""<ModelStructure> of every shipped FMU against what the code computes (issue 11).

<InitialUnknowns>: FMI 2.0 reads an entry without `dependencies` as "depends on every known"
(every input and every parameter), so a master coupling the controller and a plant output-to-input
would see an algebraic loop at initialization (OMSimulator reported "Alg. loop (size 6/22)"). The
generator writes the dependencies from the variable table (Variable::initial_inputs + every
parameter). These tests perturb each input in initialization mode and check that exactly the
declared initial unknowns move: an output computed from a measured input (the controller's set
points hold the measured posture) declares it, and no other does.

<Outputs> declare dependencies="" (no direct feed-through at communication points); that promise is
tested in test_fmu_glue.py::test_outputs_have_no_direct_feedthrough.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
import zipfile

import pytest

from conftest import SHIPPED, RawModel, _unzip


def _structure(fmu):
    with zipfile.ZipFile(fmu) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    svs = root.find("ModelVariables").findall("ScalarVariable")
    by_index = {i: sv for i, sv in enumerate(svs, start=1)}
    initial = {}
    for u in root.find("ModelStructure").find("InitialUnknowns"):
        assert "dependencies" in u.attrib, f"{fmu.name}: initial unknown {u.attrib['index']} has no dependencies"
        deps = [int(x) for x in u.attrib["dependencies"].split()]
        assert deps == sorted(set(deps)), "dependencies must be ascending and unique"
        initial[by_index[int(u.attrib["index"])].get("name")] = {by_index[d].get("name") for d in deps}
    return svs, initial


@pytest.fixture(scope="module", params=SHIPPED)
def shipped(request, fmu_path, tmp_path_factory):
    fmu = fmu_path(request.param)
    return request.param, fmu, _unzip(fmu, tmp_path_factory)


def test_initial_unknowns_depend_on_every_parameter_and_no_undeclared_input(shipped):
    name, fmu, _ = shipped
    svs, initial = _structure(fmu)
    params = {sv.get("name") for sv in svs if sv.get("causality") == "parameter"}
    inputs = {sv.get("name") for sv in svs if sv.get("causality") == "input"}
    # constants (Hoap2Plant3D's robot numbers) have initial="exact": not initial unknowns (FMI 2.0, 2.2.8)
    outputs = {sv.get("name") for sv in svs if sv.get("causality") == "output" and sv.get("variability") != "constant"}
    calculated = {sv.get("name") for sv in svs if sv.get("causality") == "calculatedParameter"}
    assert set(initial) == outputs | calculated, "every output (initial calculated) and calculated parameter is an initial unknown"
    for unknown, deps in initial.items():
        assert deps - params <= inputs, (unknown, deps - params - inputs)
        assert params <= deps, (unknown, "a parameter is missing from the dependencies")


def _initial_outputs(model, names, inputs):
    """Values of the outputs `names` in initialization mode after setting `inputs` (Real)."""
    inst = model.instance(name="deps")
    try:
        assert inst.fmi2SetupExperiment(0, 0.0, 0.0, 0, 0.0) == 0
        assert inst.fmi2EnterInitializationMode() == 0
        if inputs:
            assert inst.set_real(inputs) == 0
        reals = [n for n in names if model.vars[n].type == "Real"]
        ints = [n for n in names if model.vars[n].type in ("Integer", "Enumeration")]
        values = dict(zip(reals, inst.get_real(reals)[1]))
        if ints:
            values.update(zip(ints, inst.get_integer(ints)[1]))
        assert inst.fmi2ExitInitializationMode() == 0
        after = dict(zip(reals, inst.get_real(reals)[1]))
        return values, after
    finally:
        inst.free()


def test_initial_unknowns_move_with_exactly_the_declared_inputs(shipped):
    """Perturb one input at a time in initialization mode; the initial unknowns that change (read
    in initialization mode and after fmi2ExitInitializationMode) are the ones that declare it."""
    name, fmu, unzipdir = shipped
    svs, initial = _structure(fmu)
    model = RawModel(unzipdir)
    inputs = [sv.get("name") for sv in svs if sv.get("causality") == "input" and sv.find("Real") is not None]
    readable = [n for n in initial if model.vars[n].type in ("Real", "Integer", "Enumeration")]
    base_init, base_after = _initial_outputs(model, readable, {})
    for x in inputs:
        start = float(svs[[sv.get("name") for sv in svs].index(x)].find("Real").get("start", 0.0))
        init, after = _initial_outputs(model, readable, {x: start + 0.01})
        moved = {n for n in readable if init[n] != base_init[n]} | {n for n in after if after[n] != base_after[n]}
        declared = {n for n in readable if x in initial[n]}
        assert moved == declared, f"{name}: input {x} moves {sorted(moved)}, declared for {sorted(declared)}"


def test_fmpy_validate_finds_no_problem(shipped):
    """`fmpy validate` (schema, variable attributes, model structure): zero problems."""
    from fmpy.validation import validate_fmu

    name, fmu, _ = shipped
    assert validate_fmu(str(fmu)) == [], name
