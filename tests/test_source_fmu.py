"""The controller FMU is also a source FMU (docs/fmu.md, "Source FMU"): built from its sources/
alone with FMPy's source-FMU support, it is the same controller as the shipped binary.

Establishes: (1) sources/ is complete -- with binaries/ removed, FMPy builds a working binary from
the sources, the buildDescription.xml and the FMI headers alone, and its GUID check accepts the
shipped modelDescription.xml (the GUID is computed from the model's variable table, not from the
build); (2) the build is the same controller: a closed loop through all four phases
(`hip_saves_push`) with the rebuilt controller gives the shipped controller's result bit for bit
(both are compiled from the same files without fast-math or FMA contraction, so every operation
rounds alike); (3) both descriptions of the sources agree: FMI 2.0's <SourceFiles> in
modelDescription.xml and FMI 3.0 / 2.0.4's sources/buildDescription.xml list the same files.
"""
from __future__ import annotations

import shutil
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest

CONTROLLER = "AnkleHipController"


@pytest.fixture(scope="module")
def rebuilt(fmu_path, tmp_path_factory) -> Path:
    """The controller FMU with binaries/ removed and rebuilt from sources/ by FMPy, repacked."""
    from fmpy.build import build_platform_binary

    if shutil.which("cmake") is None:
        pytest.skip("FMPy's source-FMU build needs cmake on PATH")
    tmp = tmp_path_factory.mktemp("source_fmu")
    unz = tmp / "unzipped"
    with zipfile.ZipFile(fmu_path(CONTROLLER)) as z:
        z.extractall(unz)
    shutil.rmtree(unz / "binaries")
    build_platform_binary(unz.resolve(), build_dir=None)
    so = unz / "binaries" / "linux64" / f"{CONTROLLER}.so"
    assert so.is_file(), "FMPy built no binary from sources/"
    out = tmp / "fmus"
    out.mkdir()
    fmu = out / f"{CONTROLLER}.fmu"
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as z:
        for f in sorted(unz.rglob("*")):
            if f.is_file():
                z.write(f, f.relative_to(unz).as_posix())
    return fmu


def test_source_lists_agree(fmu_path):
    with zipfile.ZipFile(fmu_path(CONTROLLER)) as z:
        md = ET.fromstring(z.read("modelDescription.xml"))
        bd = ET.fromstring(z.read("sources/buildDescription.xml"))
        names = set(z.namelist())
    listed = [f.get("name") for f in md.findall("CoSimulation/SourceFiles/File")]
    built = [f.get("name") for f in bd.findall("BuildConfiguration/SourceFileSet/SourceFile")]
    assert listed and listed == built
    assert bd.find("BuildConfiguration").get("modelIdentifier") == CONTROLLER
    assert all(f"sources/{n}" in names for n in listed)


def test_built_from_sources_equals_the_shipped_binary(rebuilt, fmu_path):
    from anklehip.running.master import Models, simulate
    from anklehip.files.paths import scenarios_dir
    from anklehip.files.scenario import load_scenario

    sc = load_scenario(scenarios_dir() / "hip_saves_push.toml")
    shipped = simulate(sc, Models.load(), progress=False)
    from_src = simulate(sc, Models.load(controller=rebuilt, plant=fmu_path("Hoap2Plant")), progress=False)
    assert from_src.outcome == shipped.outcome == "completed"
    assert set(np.unique(shipped.data["phase"])) == {0, 1, 2, 3}
    assert shipped.data.dtype == from_src.data.dtype
    for name in shipped.data.dtype.names:
        assert np.array_equal(shipped.data[name], from_src.data[name]), name
