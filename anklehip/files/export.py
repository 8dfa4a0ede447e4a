"""The closed loop as one artefact, for tools that do not run our master:

* ``write_ssp``: an SSP 1.0 file (System Structure and Parameterization): the controller FMU and
  a plant FMU, their connections (by name, as the master connects them), the
  push force as the system's input, and the scenario's parameter values as a parameter set (.ssv).
* ``write_container_fmu``: one co-simulation FMU built with FMPy's container support that packs
  both FMUs; the push force is its only input, every plant output and the controller's outputs are
  its outputs.

Both run the loop as a co-simulation master does (every FMU steps from the values exchanged at the
last communication point), not as our master (controller first, then the plant with the
controller's new outputs): the plant receives each set point one step later. See docs/integration.md.
"""
from __future__ import annotations

import copy
import shutil
import tempfile
import uuid
import zipfile
from pathlib import Path
from typing import Any
from xml.sax.saxutils import quoteattr

from ..running.fmu import FMUError, FMUInfo, Var
from ..running.master import CLASH_PREFIX, PUSH, PUSH_Y, Models, scenario_parameters
from .scenario import Scenario

SSD_NS = ('xmlns:ssc="http://ssp-standard.org/SSP1/SystemStructureCommon" '
          'xmlns:ssd="http://ssp-standard.org/SSP1/SystemStructureDescription" '
          'xmlns:ssv="http://ssp-standard.org/SSP1/SystemStructureParameterValues"')
SSC_TYPE = {"Real": "ssc:Real", "Integer": "ssc:Integer", "Boolean": "ssc:Boolean", "String": "ssc:String"}
# Which importers each SSP variant is for (docs/integration.md, "What is tested where"): SSP 1.0
# expresses "the system's input push_force feeds the plant" as a connection from a system-level
# connector, which libcosim rejects; the other variant leaves the plant's push inputs unconnected.
SSP_VARIANTS = {
    True: "for fmpy.ssp and SSP tools that drive system inputs (OMSimulator, Silver): drive the system inputs "
          "push_force (and push_force_y with the 3D plant); libcosim rejects this variant: export the libcosim variant "
          "for it",
    False: "for libcosim (and any SSP tool): no system input and no Enumeration connectors (libcosim stops at "
           "both; the controller's phase output is then not a connector); drive the plant's push inputs (push_force, "
           "push_force_y with the 3D plant) directly (a libcosim override manipulator or scenario)",
}
COMPONENTS = ("controller", "plant")


def connections(models: Models) -> list[tuple[str, str, str, str]]:
    """(from component, from variable, to component, to variable): every controller input from the
    plant output of the same name, every plant input from the controller output of the same name."""
    c, p = models.controller, models.plant
    p_out = {v.name for v in p.by_causality("output")}
    c_out = {v.name for v in c.by_causality("output")}
    links = []
    for v in c.by_causality("input"):
        if v.name not in p_out:
            raise FMUError(f"{c.name} input {v.name!r} has no matching {p.name} output")
        links.append(("plant", v.name, "controller", v.name))
    for v in p.by_causality("input"):
        if v.name in c_out:
            links.append(("controller", v.name, "plant", v.name))
    return links


def system_inputs(models: Models) -> list[Var]:
    """The pushes: the plant inputs the system exposes as its own."""
    return [models.plant.vars[n] for n in (PUSH, PUSH_Y) if n in models.plant.vars]


def _value(type_: str, x: Any) -> str:
    if type_ == "Boolean":
        return "true" if x else "false"
    if type_ in ("Integer", "Enumeration"):
        return str(int(x))
    return repr(float(x))


def _ssv(parameters: dict[str, tuple[Var, Any]], name: str) -> str:
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             f'<ssv:ParameterSet {SSD_NS} version="1.0" name={quoteattr(name)}>', "  <ssv:Parameters>"]
    for pname, (v, x) in parameters.items():
        t = "Integer" if v.type == "Enumeration" else v.type
        lines.append(f'    <ssv:Parameter name={quoteattr(pname)}><ssv:{t} value="{_value(v.type, x)}"/></ssv:Parameter>')
    lines += ["  </ssv:Parameters>", "</ssv:ParameterSet>", ""]
    return "\n".join(lines)


def _connector(v: Var, info: FMUInfo | None = None, kind: str | None = None) -> str:
    """An SSD connector of the FMU variable's type; an Enumeration names its type (declared in the
    SSD's <ssd:Enumerations> by _enumerations, as the FMU declares it)."""
    if v.type == "Enumeration":
        typ = f"<ssc:Enumeration name={quoteattr(_declared_type(info, v).name)}/>"
    else:
        typ = f"<{SSC_TYPE[v.type]}/>"
    return f'<ssd:Connector name={quoteattr(v.name)} kind="{kind or v.causality}">{typ}</ssd:Connector>'


def _declared_type(info: FMUInfo, v: Var):
    return next(mv.declaredType for mv in info.md.modelVariables if mv.name == v.name)


def _enumerations(infos: dict[str, FMUInfo]) -> list[str]:
    """<ssd:Enumerations>: the enumeration types of the connected variables, items as the FMUs
    declare them (an SSD's enumeration names must be unique: two FMUs declaring one name differently
    is refused)."""
    types: dict[str, list[tuple[str, int]]] = {}
    for info in infos.values():
        for v in info.vars.values():
            if v.type == "Enumeration" and v.causality in ("input", "output"):
                t = _declared_type(info, v)
                items = [(it.name, int(it.value)) for it in t.items]
                if types.setdefault(t.name, items) != items:
                    raise FMUError(f"enumeration {t.name!r} is declared differently by the FMUs ({info.name})")
    if not types:
        return []
    out = ["  <ssd:Enumerations>"]
    for name, items in types.items():
        out.append(f"    <ssc:Enumeration name={quoteattr(name)}>")
        out += [f'      <ssc:Item name={quoteattr(n)} value="{x}"/>' for n, x in items]
        out.append("    </ssc:Enumeration>")
    return out + ["  </ssd:Enumerations>"]


# An SSP of the FMI 3.0 twins (SSP 1.0 components are FMUs of any FMI version): fmpy.ssp and
# libcosim import FMI 2.0 FMUs only, so nothing here runs it (docs/integration.md).
SSP_FMI3 = "its FMUs are the FMI 3.0 twins: for SSP tools that import FMI 3.0 FMUs (fmpy.ssp and libcosim do not)"


def write_ssp(path: str | Path, scenario: Scenario, models: Models, *, name: str = "AnkleHipBalance",
              system_input: bool = True, enumerations: bool | None = None) -> Path:
    """Write the closed loop of `scenario` (its controller configuration and parameter overrides;
    the push profile is the caller's input) as an SSP 1.0 archive. system_input=False leaves the
    plant's push inputs unconnected instead of connecting them to system-level inputs, for libcosim,
    which rejects a connection without a startElement (docs/integration.md; SSP_VARIANTS says which
    tools each variant is for, and the SSD says it in a comment). Enumeration outputs (the controller's
    phase) are ssc:Enumeration connectors of the FMU's enumeration type; enumerations=False leaves
    them out (none is connected), as the libcosim variant must: libcosim aborts at an Enumeration
    connector ("Don't know how to handle Enumeration type", its issue #246). Default: as
    system_input."""
    if enumerations is None:
        enumerations = system_input
    path = Path(path)
    c_over, p_over = scenario_parameters(scenario, models)
    infos = {"controller": models.controller, "plant": models.plant}
    params = {f"{comp}.{k}": (infos[comp].vars[k], x) for comp, over in (("controller", c_over), ("plant", p_over))
              for k, x in over.items()}
    links = connections(models)
    ins = system_inputs(models) if system_input else []
    ssd = ['<?xml version="1.0" encoding="UTF-8"?>',
           f'<ssd:SystemStructureDescription {SSD_NS} version="1.0" name={quoteattr(name)}>',
           f"  <!-- {SSP_VARIANTS[system_input]} -->",
           f'  <ssd:System name={quoteattr(name)} description={quoteattr(scenario.description or scenario.name)}>']
    if ins:   # an empty <ssd:Connectors> is not schema-valid: the libcosim variant has none
        ssd += ["    <ssd:Connectors>"] + [f"      {_connector(v, models.plant, 'input')}" for v in ins]
        ssd += ["    </ssd:Connectors>"]
    else:
        ssd += ["    <!-- no system connectors: the plant's push inputs are driven directly -->"]
    ssd += ["    <ssd:ParameterBindings>",
            '      <ssd:ParameterBinding source="resources/parameters.ssv"/>',
            "    </ssd:ParameterBindings>",
            "    <ssd:Elements>"]
    for comp, info in infos.items():
        ssd.append(f'      <ssd:Component name="{comp}" type="application/x-fmu-sharedlibrary" '
                   f'source="resources/{info.path.name}">')
        ssd.append("        <ssd:Connectors>")
        ssd += [f"          {_connector(v, info)}" for v in info.vars.values()
                if v.causality in ("input", "output") and (enumerations or v.type != "Enumeration")]
        ssd += ["        </ssd:Connectors>", "      </ssd:Component>"]
    ssd += ["    </ssd:Elements>", "    <ssd:Connections>"]
    ssd += [f'      <ssd:Connection startElement="{a}" startConnector="{x}" endElement="{b}" endConnector="{y}"/>'
            for a, x, b, y in links]
    ssd += [f'      <ssd:Connection startConnector="{v.name}" endElement="plant" endConnector="{v.name}"/>' for v in ins]
    ssd += ["    </ssd:Connections>", "  </ssd:System>"] + (_enumerations(infos) if enumerations else [])
    ssd += [f'  <ssd:DefaultExperiment startTime="0" stopTime="{scenario.stop_time!r}"/>',
            "</ssd:SystemStructureDescription>", ""]
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".part")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("SystemStructure.ssd", "\n".join(ssd))
        z.writestr("resources/parameters.ssv", _ssv(params, f"{scenario.name} parameters"))
        for info in infos.values():
            z.write(info.path, f"resources/{info.path.name}")
    tmp.replace(path)
    return path


def _platforms(fmu: Path) -> set[str]:
    with zipfile.ZipFile(fmu) as z:
        return {n.split("/")[1] for n in z.namelist() if n.startswith("binaries/") and n.count("/") >= 2}


def write_container_fmu(path: str | Path, scenario: Scenario, models: Models, *,
                        name: str = "AnkleHipBalance") -> Path:
    """Pack the closed loop of `scenario` into one FMU with FMPy's container support: input
    push_force (and push_force_y for the 3D plant), the plant's outputs and the controller's as
    outputs (controller outputs whose name a plant output has get the "controller." prefix), the
    scenario's parameter values as the container's parameters (start values)."""
    from fmpy.container_fmu import Configuration
    from fmpy.container_fmu.cli import create_container_fmu
    from fmpy.container_fmu.config import Component, Connection
    from fmpy.model_description import CoSimulation, DefaultExperiment, ModelDescription, ModelVariable, Unknown

    path = Path(path)
    if 3 in (models.controller.fmi_version, models.plant.fmi_version):
        raise FMUError("a container FMU packs FMI 2.0 FMUs (FMPy's container binary and its platform folders are "
                       "FMI 2.0's here): export it from the FMI 2.0 FMUs (without --fmi 3)")
    c_over, p_over = scenario_parameters(scenario, models)
    infos = {"controller": models.controller, "plant": models.plant}
    mds = {k: info.md for k, info in infos.items()}
    comps = {k: Component(name=k, filename=info.path, modelDescription=mds[k]) for k, info in infos.items()}
    md_vars = {k: {v.name: v for v in mds[k].modelVariables} for k in infos}

    md = ModelDescription()
    md.fmiVersion = "2.0"
    md.modelName = name
    md.description = (f"Closed loop of {models.controller.name} and {models.plant.name}: "
                      f"{scenario.description or scenario.name}")
    # deterministic: the same scenario gives the same container
    md.instantiationToken = md.guid = "{%s}" % uuid.uuid5(uuid.NAMESPACE_URL, f"anklehip/{name}/{scenario.name}")
    md.coSimulation = CoSimulation(modelIdentifier="container_fmu")
    md.coSimulation.fixedInternalStepSize = scenario.step
    md.defaultExperiment = DefaultExperiment(startTime="0", stopTime=repr(scenario.stop_time), stepSize=repr(scenario.step))
    mappings: dict[ModelVariable, list] = {}

    def add(vname, type_, causality, variability, description, comp=None, cvar=None, start=None, initial=None):
        # FMPy's writer has no type definitions: an enumeration (phase, contact_mode) is its Integer
        type_ = "Integer" if type_ == "Enumeration" else type_
        v = ModelVariable(name=vname, valueReference=len(md.modelVariables), type=type_, causality=causality,
                          variability=variability, description=description, initial=initial)
        if start is not None:   # as text: container.json wants strings
            v.start = _value(type_, start)
        md.modelVariables.append(v)
        if comp:
            mappings[v] = [(comps[comp], md_vars[comp][cvar])]
        return v

    # FMPy 0.3.32's container binary reads value reference 0 as the time and the mapped variables
    # (container.json) as value references 1, 2, ...: the time comes first, without a mapping.
    add("time", "Real", "independent", "continuous", "Simulation time")
    for v in system_inputs(models):
        add(v.name, "Real", "input", "continuous", v.description, "plant", v.name, start=v.start)
    p_outs = [v for v in models.plant.by_causality("output")]
    for v in p_outs:
        add(v.name, v.type, "output", v.variability, v.description, "plant", v.name)
    p_names = {v.name for v in p_outs}
    for v in models.controller.by_causality("output"):
        add(CLASH_PREFIX + v.name if v.name in p_names else v.name, v.type, "output", v.variability,
            v.description, "controller", v.name)
    for comp, over in (("controller", c_over), ("plant", p_over)):
        for k, x in over.items():
            pv = infos[comp].vars[k]
            add(f"{comp}.{k}", pv.type, "parameter", pv.variability, pv.description, comp, k, start=x, initial="exact")
    md.numberOfEventIndicators = 0
    # No feed-through (push_force acts in the next doStep); initial outputs from parameters only.
    params = [v for v in md.modelVariables if v.causality == "parameter"]
    outs = [v for v in md.modelVariables if v.causality == "output"]
    md.outputs = [Unknown(variable=v, dependencies=[]) for v in outs]
    md.initialUnknowns = [Unknown(variable=v, dependencies=params) for v in outs]

    def connector(comp, vname):
        # FMPy 0.3.32 writes a connection's variableType from the variable's FMI 2 type ("Real"),
        # which its container binary rejects ("unknown variant 'Real'"): give it the FMI 3 name.
        v = copy.copy(md_vars[comp][vname])
        v.type = {"Real": "Float64", "Integer": "Int32", "Enumeration": "Int32"}.get(v.type, v.type)
        return v

    conns = [Connection(startElement=comps[a], startConnectors=[connector(a, x)], endElement=comps[b],
                        endConnectors=[connector(b, y)]) for a, x, b, y in connections(models)]
    config = Configuration(parallelDoStep=False, modelDescription=md, components=list(comps.values()),
                           connections=conns, variableMappings=mappings)
    path.parent.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="container_"))
    try:
        packed = work / "packed.fmu"
        (work / "unzipped").mkdir()          # create_container_fmu empties it first
        create_container_fmu(config, work / "unzipped", packed)
        # FMPy adds its container binary for every platform it has; keep those the nested FMUs
        # also have binaries for (a darwin64 container of linux64/win64 FMUs cannot run).
        platforms = set.intersection(*(_platforms(info.path) for info in infos.values()))
        tmp = path.with_name(path.name + ".part")
        with zipfile.ZipFile(packed) as src, zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as dst:
            for item in src.infolist():
                parts = item.filename.split("/")
                if parts[0] == "binaries" and len(parts) > 2 and parts[1] not in platforms:
                    continue
                dst.writestr(item, src.read(item))
        tmp.replace(path)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return path
