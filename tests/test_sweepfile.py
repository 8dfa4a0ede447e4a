"""Sweep files (anklehip/running/sweepfile.py, `anklehip sweep FILE`): what a file may say and how a wrong
one is refused (file, key, value named; exit 2, nothing run), the points a grid and a seeded random
sample make, how a point's values become the push and the parameters, and a small sweep end to
end: one row per point with the outcome metrics, the figures, and a second run that only resumes;
the capability map (anklehip/analysis/capability.py: survive_boundary, plot_capability; docs/capability.md).
"""
from __future__ import annotations

import csv
import re
import random
from pathlib import Path

import pytest

from anklehip.analysis.capability import plot_capability, survive_boundary
from anklehip.cli import main
from anklehip.files.paths import scenarios_dir
from anklehip.files.scenario import ScenarioError
from anklehip.running.sweep import sweep
from anklehip.running.sweepfile import load_sweep_file, point_setup
from test_bounds import PARAMS

BASE = """description = "test"
scenario = "hip_saves_push"
stop_time = 4.0
[push]
t = 1.0
rise = 0.05
[[variant]]
name = "ankle_only"
controller = { hip_strategy_enabled = 0 }
[[variant]]
name = "default"
"""


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "s.toml"
    p.write_text(text)
    return p


def test_grid_and_random_points(tmp_path):
    sf = load_sweep_file(_write(tmp_path, BASE + '[grid]\n"push.force" = "4:8:2"\n"push.duration" = [0.1, 0.5]\n'))
    vals = sf.values()
    assert len(vals) == 6 and vals[0] == {"push.force": 4.0, "push.duration": 0.1}
    assert len(sf.specs(None, "native")) == 12 and len({s["id"] for s in sf.specs(None, "native")}) == 12
    r = load_sweep_file(_write(tmp_path, BASE + '[random]\nn = 5\nseed = 3\n"push.force" = [2, 20]\n'))
    a, b = r.values(), r.values()
    assert a == b and len(a) == 5 and all(2 <= x["push.force"] <= 20 for x in a)


def test_point_values_become_the_push_and_parameters(tmp_path):
    sf = load_sweep_file(_write(tmp_path, BASE + '[grid]\n"push.force" = [6]\n'))
    prof, prof_y, along, c, p, f = point_setup(sf, {"push.force": 6.0, "push.duration": 0.4, "push.direction": -1,
                                                    "push.height": 0.3, "controller.Ka": 20.0,
                                                    "faults.zmp_noise": 0.001}, None)
    assert prof.peak() == -6.0 and prof.events()[0][0] == pytest.approx(1.0)
    assert prof_y.peak() == 0.0 and along.peak() == -6.0
    assert p == {"h_push": 0.3} and c == {"Ka": 20.0} and f == {"zmp_noise": 0.001}


@pytest.mark.parametrize("extra,match", [
    ('nosuch = 1\n[grid]\n"push.force" = [6]\n', r"s\.toml: variant\[1\]\.nosuch: unknown key"),
    ('[grid]\n"push.weight" = [6]\n', r"grid\.push\.weight: unknown key to sweep"),
    ('[grid]\n"push.force" = "6:2"\n', r"grid\.push\.force.*6:2"),
    ('[grid]\n"push.force" = [6]\n[random]\nn = 3\n"push.force" = [1, 2]\n', r"exactly one of \[grid\]"),
    ('[random]\nn = 3\n"push.force" = [5, 2]\n', r"random\.push\.force: needs low < high"),
    ('[random]\n"push.force" = [1, 2]\n', r"random\.n: required key missing"),
])
def test_bad_files_name_the_key(tmp_path, extra, match):
    with pytest.raises(ScenarioError, match=match):
        load_sweep_file(_write(tmp_path, BASE + extra))


def test_unknown_top_level_key(tmp_path):
    with pytest.raises(ScenarioError, match=r"s\.toml: nosuch: unknown key"):
        load_sweep_file(_write(tmp_path, 'nosuch = 1\n' + BASE + '[grid]\n"push.force" = [6]\n'))


def test_cli_refuses_unknown_parameters_before_running(tmp_path, capsys):
    p = _write(tmp_path, BASE + '[grid]\n"controller.nosuch" = [1, 2]\n')
    assert main(["sweep", str(p), "--workers", "1", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "nosuch" in err and "s.toml" in err and not (tmp_path / "out" / "points.jsonl").exists()


def test_small_sweep_end_to_end_and_resume(tmp_path, capsys):
    p = _write(tmp_path, BASE + '[grid]\n"push.force" = [6, 30]\n"push.duration" = [0.2, 1.0]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(p), "--workers", "1", "--engine", "native", "--out", str(out)]) == 0
    with open(out / "points.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 8
    for col in ("variant", "push.force", "push.duration", "outcome", "fell_at", "peak_zmp", "phases",
                "time_to_recover", "peak_hip", "solver_steps", "rhs_evals"):
        assert col in rows[0]
    by = {(r["variant"], float(r["push.force"]), float(r["push.duration"])): r for r in rows}
    assert by[("default", 6.0, 0.2)]["outcome"] == "completed"
    assert by[("ankle_only", 30.0, 1.0)]["outcome"] == "fell"
    for fig in ("points_outcome.png", "points_peak_zmp.png", "points_recovery.png"):
        assert (out / fig).stat().st_size > 1000
    # the printout: per variant how many stood, and the boundary of each duration (6 N stood at
    # 0.2 s for every variant, 30 N fell everywhere: the boundary is 6 N, not ">=")
    printed = capsys.readouterr().out
    assert "largest push.force that stood, every smaller one standing too [N], by push.duration:" in printed
    names = {r["variant"] for r in rows}       # (the bounds' lines follow the variants')
    boundary = [ln.split() for ln in printed.splitlines() if ln.startswith("  ") and "0.2:" in ln
                and ln.split()[0] in names]
    assert len(boundary) == len({r["variant"] for r in rows}) and all(ln[1:3] == ["0.2:", "6"] for ln in boundary), printed
    assert main(["sweep", str(p), "--workers", "1", "--engine", "native", "--out", str(out)]) == 0
    assert "8 from an earlier run" in capsys.readouterr().out


def test_committed_sweep_files_load():
    files = sorted((scenarios_dir() / "sweeps").glob("*.toml"))
    assert files
    for f in files:
        sf = load_sweep_file(f)
        assert sf.specs(None, "native")


# ---------------------------------------------------------------------------------------------
# capability map

CAP_HEAD = """scenario = "hip_saves_push"
stop_time = 3.0
[push]
t = 1.0
rise = 0.05
[[variant]]
name = "a"
[[variant]]
name = "b"
plant = { h_push = 0.3 }
"""


def _cap_sweep(tmp_path: Path, grid: str, head: str = CAP_HEAD):
    p = tmp_path / "cap.toml"
    p.write_text(head + grid)
    return load_sweep_file(p)


def _cap_rows(kx: str, table: dict[str, dict[float, list[tuple[float, str]]]]) -> list[dict]:
    rows = [{"variant": v, kx: x, "push.force": f, "outcome": o}
            for v, by_x in table.items() for x, pts in by_x.items() for f, o in pts]
    random.Random(1).shuffle(rows)
    return rows


def test_survive_boundary_on_synthetic_rows():
    """Establishes: per x, the boundary is the largest force that stood with every smaller force
    standing too (a stand above a fall does not count; an error counts as not standing; 0 when the
    smallest force fell), flagged when every force tried stood; rows are taken in any order and
    other variants' rows are ignored."""
    rows = _cap_rows("push.duration", {
        "a": {0.1: [(2, "completed"), (4, "completed"), (6, "fell"), (8, "completed")],
              1.0: [(2, "fell"), (4, "fell")],
              2.0: [(2, "completed"), (4, "completed"), (8, "completed")],
              0.5: [(2, "completed"), (4, "error"), (6, "completed")]},
        "b": {0.1: [(2, "fell")]}})
    xs, fs, top = survive_boundary(rows, "a", "push.duration")
    assert xs.tolist() == [0.1, 0.5, 1.0, 2.0]
    assert fs.tolist() == [4.0, 2.0, 0.0, 8.0]
    assert top.tolist() == [False, False, False, True]
    xs, fs, top = survive_boundary(rows, "b", "push.duration")
    assert xs.tolist() == [0.1] and fs.tolist() == [0.0] and not top[0]
    assert len(survive_boundary(rows, "nosuch", "push.duration")[0]) == 0


def test_plot_capability_applies_to_force_by_duration_or_height(tmp_path):
    """Establishes: plot_capability writes capability.png for a grid over push.force and
    push.duration (log axis) or push.height, also for a push on the chest, and returns None for
    any other sweep (other keys, one key, random samples) and for parameters that are not the
    sagittal plant's."""
    pts = {0.1: [(4, "completed"), (8, "fell")], 1.0: [(4, "completed"), (8, "completed")]}
    sf = _cap_sweep(tmp_path, '[grid]\n"push.force" = [4, 8]\n"push.duration" = [0.1, 1.0]\n')
    out = plot_capability(sf, _cap_rows("push.duration", {"a": pts, "b": pts}), tmp_path, PARAMS)
    assert out == tmp_path / "capability.png" and out.stat().st_size > 1000
    out.unlink()
    hpts = {0.3: pts[0.1], 0.4: pts[1.0]}
    chest = CAP_HEAD.replace("rise = 0.05", "rise = 0.05\ndirection = -1")
    sf = _cap_sweep(tmp_path, '[grid]\n"push.height" = [0.3, 0.4]\n"push.force" = [4, 8]\n', chest)
    assert plot_capability(sf, _cap_rows("push.height", {"a": hpts}), tmp_path, PARAMS) == tmp_path / "capability.png"
    assert (tmp_path / "capability.png").is_file()
    for grid in ('[grid]\n"push.force" = [4, 8]\n"push.rise" = [0.01, 0.1]\n', '[grid]\n"push.force" = [4, 8]\n',
                 '[random]\nn = 4\n"push.force" = [2, 8]\n"push.duration" = [0.1, 1.0]\n'):
        assert plot_capability(_cap_sweep(tmp_path, grid), [], tmp_path, PARAMS) is None
    sf = _cap_sweep(tmp_path, '[grid]\n"push.force" = [4, 8]\n"push.duration" = [0.1, 1.0]\n')
    assert plot_capability(sf, [], tmp_path, {"g": 9.81, "h_push": 0.335}) is None


def test_sweep_writes_the_capability_map(tmp_path, capsys):
    """Establishes: `anklehip sweep FILE` on a 2 x 2 grid over push.force and push.duration runs the
    points and writes capability.png next to the other figures, naming it in its output, and prints
    the bounds with the flat-footed optimum (docs/capability.md section 8) at the grid's durations."""
    p = tmp_path / "tiny.toml"
    p.write_text(CAP_HEAD.split("[[variant]]")[0] + '[grid]\n"push.force" = [6, 30]\n"push.duration" = [0.2, 1.0]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(p), "--workers", "1", "--engine", "native", "--out", str(out)]) == 0
    assert (out / "capability.png").stat().st_size > 1000
    printed = capsys.readouterr().out
    assert f"figure {out / 'capability.png'}" in printed
    # the bounds at the grid's durations under the boundaries, the flat-footed optimum among them
    assert "  flat-footed opt. 0.2: 27.1  1: 16.1" in printed


# ---------------------------------------------------------------------------------------------
# push.angle: the push's direction in the horizontal plane; the polar capability map

BASE3D = BASE.replace('scenario = "hip_saves_push"', 'scenario = "paper_five_pushes_3d"')


def test_push_angle_splits_the_force_into_x_and_y(tmp_path):
    """Establishes: push.angle splits the peak force F into F cos(angle) along x (the scenario's push)
    and F sin(angle) along y (its push_y), exactly on the axes (180 deg has no y push at all); the
    push along its own direction peaks at F; a fixed [push] angle works like a swept one."""
    sf = load_sweep_file(_write(tmp_path, BASE3D + '[grid]\n"push.angle" = [0, 90, 135, 180, 270]\n"push.force" = [8]\n'))
    assert sf.values()[0] == {"push.angle": 0.0, "push.force": 8.0}
    got = {}
    for a in (0, 90, 135, 180, 270):
        pt = point_setup(sf, {"push.angle": float(a), "push.force": 8.0})
        got[a] = (pt.push.peak(), pt.push_y.peak(), pt.along.peak())
        assert pt.push.events() == ([] if a in (90, 270) else [(1.0, 1.5)])
    r = 8.0 / 2 ** 0.5
    assert got[0] == (8.0, 0.0, 8.0) and got[90] == (0.0, 8.0, 8.0) and got[180] == (-8.0, 0.0, 8.0)
    assert got[270] == (0.0, -8.0, 8.0)
    assert got[135][0] == pytest.approx(-r, rel=1e-15) and got[135][1] == pytest.approx(r, rel=1e-15)
    fixed = load_sweep_file(_write(tmp_path, BASE3D.replace("rise = 0.05", "rise = 0.05\nangle = 90")
                                   + '[grid]\n"push.force" = [8]\n'))
    pt = point_setup(fixed, {"push.force": 8.0})
    assert (pt.push.peak(), pt.push_y.peak()) == (0.0, 8.0)


@pytest.mark.parametrize("text,match", [
    (BASE + '[grid]\n"push.angle" = [0, 90]\n"push.force" = [6]\n',
     r"s\.toml: grid\.push\.angle: 90 deg: a push off the x axis .*3D plant.*hip_saves_push"),
    (BASE.replace("rise = 0.05", "rise = 0.05\nangle = 45") + '[grid]\n"push.force" = [6]\n',
     r"s\.toml: push\.angle: 45 deg: .*sagittal plant"),
    (BASE + '[random]\nn = 3\n"push.angle" = [0, 30]\n',
     r"s\.toml: random\.push\.angle: 0 deg: .*3D plant"),
    (BASE3D.replace("rise = 0.05", "rise = 0.05\ndirection = -1") + '[grid]\n"push.angle" = [0, 90]\n',
     r"s\.toml: push\.direction: give the push's direction once: grid\.push\.angle or push\.direction"),
    (BASE3D + '[grid]\n"push.angle" = [0, 90]\n"push.direction" = [1, -1]\n',
     r"s\.toml: grid\.push\.direction: give the push's direction once"),
])
def test_push_angle_refused_where_it_cannot_act(tmp_path, text, match):
    """Establishes: a push off the x axis on a sagittal base scenario, and an angle together with
    push.direction, are refused naming the file and the key (a random range of angles is always off
    the axis)."""
    with pytest.raises(ScenarioError, match=match):
        load_sweep_file(_write(tmp_path, text))


def test_push_angle_on_the_x_axis_runs_on_the_sagittal_plant(tmp_path):
    """Establishes: angles on the x axis (0, 180, 360, -180 deg) are accepted on a sagittal base and are
    pushes on the back and on the chest, with no sideways push."""
    sf = load_sweep_file(_write(tmp_path, BASE + '[grid]\n"push.angle" = [0, 180, 360, -180]\n"push.force" = [6]\n'))
    peaks = [(pt.push.peak(), pt.push_y.peak()) for pt in (point_setup(sf, v) for v in sf.values())]
    assert peaks == [(6.0, 0.0), (-6.0, 0.0), (6.0, 0.0), (-6.0, 0.0)]


def test_cli_refuses_an_angle_on_the_sagittal_plant_before_running(tmp_path, capsys):
    p = _write(tmp_path, BASE + '[grid]\n"push.angle" = [0, 90]\n"push.force" = [6]\n')
    assert main(["sweep", str(p), "--workers", "1", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "grid.push.angle" in err and "s.toml" in err and not (tmp_path / "out" / "points.jsonl").exists()


POLAR = BASE3D.replace("stop_time = 4.0", "stop_time = 3.0").split("[[variant]]")[0] + '[[variant]]\nname = "default"\n'


def test_polar_sweep_end_to_end(tmp_path, capsys):
    """Establishes: `anklehip sweep FILE` on the 3D plant over push.angle x push.force pushes from the
    side (a side push moves the lateral ZMP: peak_zmp_y; on the x axis it stays near the middle),
    writes the polar capability map as capability.png and prints each direction's boundary with the
    bounds in that direction; a 40 N push of 0.5 s fells the robot in every direction, 4 N in none."""
    p = _write(tmp_path, POLAR + '[grid]\n"push.angle" = [0, 90, 180, 270]\n"push.force" = [4, 40]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(p), "--workers", "1", "--engine", "native", "--out", str(out)]) == 0
    with open(out / "points.csv", newline="") as f:
        rows = {(float(r["push.angle"]), float(r["push.force"])): r for r in csv.DictReader(f)}
    assert len(rows) == 8
    assert all(rows[(a, 4.0)]["outcome"] == "completed" and rows[(a, 40.0)]["outcome"] == "fell"
               for a in (0, 90, 180, 270))
    zy = {a: float(rows[(a, 4.0)]["peak_zmp_y"]) for a in (0, 90, 180, 270)}
    assert zy[90] > 0.01 and zy[270] < -0.01 and abs(zy[0]) < 0.002 and abs(zy[180]) < 0.002, zy
    assert float(rows[(90, 4.0)]["peak_force"]) == 4.0 and abs(float(rows[(90, 4.0)]["peak_zmp"])) < 0.01
    assert (out / "capability.png").stat().st_size > 1000
    printed = capsys.readouterr().out
    assert "by push.angle [deg]:" in printed and f"figure {out / 'capability.png'}" in printed
    line = next(ln.split() for ln in printed.splitlines() if ln.startswith("  default") and "0:" in ln)
    assert line[1:] == ["0:", "4", "90:", "4", "180:", "4", "270:", "4"], printed
    static = next(ln for ln in printed.splitlines() if ln.startswith("  static tipping"))
    assert "0: 12.0" in static and "90: 15.0" in static and "180: 8.0" in static, static


def _polar_params():
    from test_bounds import FRONTAL
    return {**PARAMS, **FRONTAL}


def test_polar_map_applies_to_force_by_angle_grids(tmp_path):
    """Establishes: the polar map is drawn for a grid over push.force and push.angle (one panel) and
    with a third key push.duration or push.height (a panel per value), as capability.png; not for
    other third keys, random samples, or parameters without the stance's numbers."""
    import matplotlib.pyplot as plt

    from anklehip.analysis.capability import capability_figure, polar_panels
    pts = {0.0: [(4, "completed"), (8, "fell")], 90.0: [(4, "completed"), (8, "completed")],
           180.0: [(4, "fell")], 270.0: [(4, "completed"), (8, "fell")]}
    head = POLAR.replace('scenario = "paper_five_pushes_3d"', 'scenario = "paper_five_pushes_3d"')
    sf = _cap_sweep(tmp_path, '[grid]\n"push.force" = [4, 8]\n"push.angle" = [0, 90, 180, 270]\n', head)
    assert polar_panels(sf) == [(None, None)]
    out = plot_capability(sf, _cap_rows("push.angle", {"default": pts}), tmp_path, _polar_params())
    assert out == tmp_path / "capability.png" and out.stat().st_size > 1000
    sf = _cap_sweep(tmp_path, '[grid]\n"push.angle" = [0, 90, 180, 270]\n"push.force" = [4, 8]\n'
                    '"push.duration" = [1.0, 0.2]\n', head)
    assert polar_panels(sf) == [("push.duration", 1.0), ("push.duration", 0.2)]
    rows = [dict(r, **{"push.duration": d}) for d in (1.0, 0.2) for r in _cap_rows("push.angle", {"default": pts})]
    fig = capability_figure(sf, rows, _polar_params())
    assert len([ax for ax in fig.axes if ax.name == "polar"]) == 2
    plt.close(fig)
    for grid in ('[grid]\n"push.force" = [4, 8]\n"push.angle" = [0, 90]\n"push.rise" = [0.01, 0.1]\n',
                 '[random]\nn = 4\n"push.force" = [2, 8]\n"push.angle" = [0, 90]\n'):
        sf = _cap_sweep(tmp_path, grid, head)
        assert polar_panels(sf) is None and plot_capability(sf, [], tmp_path, _polar_params()) is None
    sf = _cap_sweep(tmp_path, '[grid]\n"push.force" = [4, 8]\n"push.angle" = [0, 90]\n', head)
    assert plot_capability(sf, [], tmp_path, PARAMS) is None


def test_fixed_angle_duration_map_uses_the_bounds_in_that_direction(tmp_path):
    """Establishes: a force x duration map of pushes with a fixed push.angle draws the bounds in that
    direction (at 90 deg the side's static tipping force, not the back's)."""
    import matplotlib.pyplot as plt

    from anklehip.analysis.bounds import static_tipping_force_3d
    from anklehip.analysis.capability import capability_figure
    from test_bounds import ST
    head = POLAR.replace("rise = 0.05", "rise = 0.05\nangle = 90")
    sf = _cap_sweep(tmp_path, '[grid]\n"push.force" = [4, 8]\n"push.duration" = [0.2, 1.0]\n', head)
    fig = capability_figure(sf, [], _polar_params())
    static = next(ln for ln in fig.axes[0].lines if ln.get_label().startswith("static"))
    assert static.get_ydata()[0] == pytest.approx(static_tipping_force_3d(ST, 90.0), rel=1e-12)
    assert "toward 90 deg" in fig.axes[0].get_title()
    plt.close(fig)


SIDE = """description = "side push, both controllers"
scenario = "paper_five_pushes_3d"
stop_time = 4.0
[push]
t = 1.0
duration = 1.0
rise = 0.3
angle = 90
[[variant]]
name = "sagittal"
[[variant]]
name = "3d"
controller_model = "3d"
"""


def test_controller_model_variant_runs_the_3d_controller(tmp_path):
    """Establishes: a variant's `controller_model = "3d"` runs AnkleHipController3D on the base
    scenario (docs/controller.md section 11.5: a 1 s side push of 16.5 N fells the robot under the
    sagittal controller, whose roll servos hold it to 15 N, and the 3D controller's lateral lean
    stands it), in the same sweep as the scenario's own controller; the rows carry the frontal
    outputs' effect (the lateral ZMP stays inside the sole edge)."""
    p = _write(tmp_path, SIDE + '[grid]\n"push.force" = [16.5]\n')
    res = sweep(str(p), workers=1, engine="native", progress=False)
    rows = {r["variant"]: r for r in res.rows}
    assert rows["sagittal"]["outcome"] == "fell" and rows["3d"]["outcome"] == "completed", rows
    assert abs(rows["3d"]["peak_zmp_y"]) < 0.0715


@pytest.mark.parametrize("variant,match", [
    ('controller_model = "4d"', r"variant 3d: unknown controller model '4d'"),
    ('controller_model = "3d"\ncontroller = { Ka_y = -1 }', r"AnkleHipController3D.fmu: parameter 'Ka_y' = -1 is outside.*variant 3d"),
])
def test_controller_model_variant_checked_before_running(tmp_path, capsys, variant, match):
    p = _write(tmp_path, SIDE.replace('controller_model = "3d"', variant) + '[grid]\n"push.force" = [5]\n')
    assert main(["sweep", str(p), "--workers", "1", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert re.search(match, err) and "s.toml" in err, err
    assert not (tmp_path / "out" / "points.jsonl").exists()


def test_controller_model_variant_needs_the_3d_plant(tmp_path, capsys):
    p = _write(tmp_path, BASE.replace('name = "default"', 'name = "frontal"\ncontroller_model = "3d"')
               + '[grid]\n"push.force" = [6]\n')
    assert main(["sweep", str(p), "--workers", "1", "--out", str(tmp_path / "out")]) == 2
    assert re.search(r"s\.toml: variant frontal: the 3D controller needs the 3D plant", capsys.readouterr().err)


def test_cli_variant_spec_takes_a_controller_model():
    from anklehip.running.sweep import parse_variant
    v = parse_variant("frontal:controller_model=3d,controller.Ka_y=100")
    assert (v.name, v.controller_model, v.controller) == ("frontal", "3d", {"Ka_y": 100.0})
    assert parse_variant("x").digest() == parse_variant("x").digest() != v.digest()
