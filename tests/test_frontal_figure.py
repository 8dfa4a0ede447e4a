"""The frontal plane's Fig. 5 (anklehip/analysis/frontal_cycle.py; no FMUs needed): drawn for a
result of the 3D controller (the column phase_y) and for no other, with its panels' content -- the
lateral phases shaded, the frontal and the legs' roll references, p_y with the outer sole edges at
±(ankle_y + sole_width/2) of the robot header, r_y measured, the controller's r_y and r_y^d, the
sideways push -- each line the result's column over the window of the first side push. The layout
rules (legends clear of each other and of the data) are test_plots_layout's, which draws it too."""
from __future__ import annotations

import numpy as np
import pytest
from matplotlib.colors import to_rgb

from anklehip.analysis import frontal_cycle as fc
from anklehip.analysis import plots
from anklehip.analysis.bounds import HEADER_NAMES
from conftest import NOMINAL


def frontal_synthetic(t_end=6.0, h=0.01):
    """A side push of 17 N from 1 s to 2 s met by every lateral phase, with the 3D controller's
    frontal and per-leg outputs and the 3D plant's lateral ZMP, CoM and roll angles."""
    t = np.arange(0, t_end + h / 2, h)
    names = ["time", "zmp_y", "com_y", "controller.com_y", "com_y_desired", "phi_ref", "psi_ref", "dphi_ref",
             "dpsi_ref", "k_w_y", "disturbance_moment_y", "phase_y", "push_force_y", "fz_left", "fz_right",
             "theta_ankle", "theta_hip", "zmp_x", "com_x", "phase", "push_force"]
    names += [f"q_{s}_{j}{r}" for s in ("left", "right") for j in ("hip_roll", "ankle_roll") for r in ("", "_ref")]
    d = np.zeros(len(t), [(n, float) for n in names])
    bump = np.exp(-((t - 2.2) / 0.4) ** 2)
    d["time"] = t
    d["push_force_y"] = np.where((t > 1.0) & (t < 2.0), 17.0, 0.0)
    d["zmp_y"], d["com_y"] = 0.060 * bump, -0.012 * bump
    d["controller.com_y"] = d["com_y"] + 0.0005
    d["com_y_desired"] = -0.015 * bump
    d["phi_ref"], d["psi_ref"] = -0.06 * bump, 0.05 * bump
    for s, sg in (("left", 1), ("right", -1)):
        d[f"q_{s}_ankle_roll_ref"] = 0.06 * bump
        d[f"q_{s}_hip_roll_ref"] = (-0.06 + 0.02 * sg) * bump
        d[f"q_{s}_ankle_roll"] = 0.9 * d[f"q_{s}_ankle_roll_ref"]
        d[f"q_{s}_hip_roll"] = 0.9 * d[f"q_{s}_hip_roll_ref"]
    d["phase_y"] = np.select([t < 1.4, t < 1.8, t < 2.4, t < 3.0], [0, 1, 2, 3], 0)
    return d


def _edge():
    """The header's outer sole edge, by the names the plant's parameters use."""
    return fc.support_edge({k: NOMINAL[m] for k, m in HEADER_NAMES.items() if m in NOMINAL})


def _lines(ax) -> dict:
    return {ln.get_label(): ln for ln in ax.get_lines() if not ln.get_label().startswith("_")}


def test_the_support_edge_is_the_header_s():
    assert _edge() == pytest.approx(NOMINAL["ANKLE_Y"] + NOMINAL["SOLE_WIDTH"] / 2, abs=1e-15)
    assert 0.06 < _edge() < 0.08          # HOAP-2: ±71.5 mm (docs/capability.md section 7)
    assert fc.support_edge({"ankle_y": 0.039}) is None


def test_written_for_the_3d_controller_and_for_no_other(tmp_path):
    from anklehip.running.run import make_figures
    from test_plots_layout import synthetic
    files = make_figures("side", frontal_synthetic(), tmp_path, progress=False,
                         header={m: NOMINAL[m] for m in ("ANKLE_Y", "SOLE_WIDTH")})
    assert "side_fig5_frontal.png" in [f.name for f in files]
    assert (tmp_path / "side_fig5_frontal.png").stat().st_size > 10000
    files = make_figures("sag", synthetic(), tmp_path, progress=False)
    assert [f.name for f in files] == ["sag_overview.png", "sag_fig4_joint_angles.png", "sag_fig5_first_cycle.png"]
    assert not fc.is_frontal(synthetic())


def test_panels_and_their_content():
    d = frontal_synthetic()
    edge = _edge()
    fig = fc.frontal_cycle_figure(d, edge=edge, title="side")
    try:
        ax = fig.axes
        assert [x.get_ylabel() for x in ax] == ["frontal ref [deg]", "leg roll [deg]", "y [mm] (+ = left)",
                                                "p_y − r_y [mm]", "push y [N]"]
        assert ax[0].get_title() == "side"
        # the window: from 0.5 s before the push (1.01 s) until the lateral phase is back at 0 (3.0 s) + 1.5 s
        w = (d["time"] >= 0.51 - 1e-9) & (d["time"] <= 4.5 + 1e-9)
        t = d["time"][w]

        def same(line, col, scale):
            x, y = line.get_data()
            assert np.array_equal(x, t), line.get_label()
            assert np.allclose(y, scale * d[col][w], rtol=0, atol=1e-12), line.get_label()

        ref = _lines(ax[0])
        assert set(ref) == {"φ ref (pivot leg's lean)", "ψ ref (link 2's lean)"}
        same(ref["φ ref (pivot leg's lean)"], "phi_ref", 180 / np.pi)
        same(ref["ψ ref (link 2's lean)"], "psi_ref", 180 / np.pi)
        legs = _lines(ax[1])
        for side in ("left", "right"):
            for joint in ("hip_roll", "ankle_roll"):
                lab = f"{side} {joint.replace('_', ' ')}"
                same(legs[lab], f"q_{side}_{joint}", 180 / np.pi)
                same(legs[lab + " ref"], f"q_{side}_{joint}_ref", 180 / np.pi)
                assert legs[lab + " ref"].get_linestyle() == "--" and legs[lab].get_linestyle() == "-"
                assert legs[lab + " ref"].get_color() == legs[lab].get_color()
        y = _lines(ax[2])
        same(y["ZMP p_y"], "zmp_y", 1000)
        same(y["CoM r_y (measured)"], "com_y", 1000)
        same(y["r_y (controller, F2)"], "controller.com_y", 1000)
        same(y["r_y^d"], "com_y_desired", 1000)
        edges = [ln for ln in ax[2].get_lines() if ln.get_linestyle() == ":"]
        assert sorted(float(ln.get_ydata()[0]) for ln in edges) == pytest.approx([-1000 * edge, 1000 * edge])
        assert y["outer sole edges"] in edges
        v = _lines(ax[3])["p_y − r_y (measured)"].get_ydata()
        assert np.allclose(v, 1000 * (d["zmp_y"] - d["com_y"])[w], rtol=0, atol=1e-12)
        assert np.allclose(ax[4].get_lines()[0].get_ydata(), d["push_force_y"][w])
        # the lateral phases, shaded on every panel: phase 2 (hip) from 1.8 s to 2.4 s
        for x in ax:
            spans = [p for p in x.patches if np.allclose(p.get_facecolor()[:3], to_rgb(plots.PHASE_COLORS[2]))]
            assert len(spans) == 1
            ext = spans[0].get_path().transformed(spans[0].get_patch_transform()).get_extents()
            assert (ext.x0, ext.x1) == pytest.approx((1.8, 2.4), abs=0.011)
        assert len(fig.legends) == 1          # the phase legend below the panels
    finally:
        plots.plt.close(fig)


def test_no_edges_without_the_stance_numbers_and_no_shading_in_phase_0():
    """A run whose lateral phase stays 0 (the defaults: the lateral hip strategy off) has no shaded
    phase and no phase legend; without the stance numbers no edges are drawn."""
    d = frontal_synthetic()
    d["phase_y"] = 0
    fig = fc.frontal_cycle_figure(d)
    try:
        assert not fig.legends and not any(x.patches for x in fig.axes)
        assert "outer sole edges" not in _lines(fig.axes[2])
        t = fig.axes[0].get_lines()[0].get_xdata()     # window: 0.5 s before the push .. 2 s after its end + 1.5 s
        assert (t[0], t[-1]) == pytest.approx((0.51, 5.5), abs=1e-9)
    finally:
        plots.plt.close(fig)


# ----------------------------------------------------------------------------------------------
# the animation's rear view: each leg from its own joint angles

def _rear_row(**q):
    names = ["time", "foot_roll", "zmp_y", "com_y", "imu_roll"] + [f"q_{s}_{j}" for s in ("left", "right")
                                                                      for j in plots.LEG_JOINTS]
    d = np.zeros(1, [(n, float) for n in names])
    for k, v in q.items():
        d[k] = v
    return d


def test_rear_view_draws_the_parallelogram_of_the_lateral_ankle_strategy():
    """Ankle roll φ and hip roll −φ on both legs (docs/controller.md §11.1): both hips move by
    l1 sin φ toward +y at the same height (the pelvis level), the legs straight."""
    g = plots.Geometry()
    phi = 0.1
    p = plots._frontal_pose(_rear_row(q_left_ankle_roll=phi, q_right_ankle_roll=phi, q_left_hip_roll=-phi,
                                      q_right_hip_roll=-phi), 0, g, 0.0)
    for side, ya in (("left", g.hip_half_width), ("right", -g.hip_half_width)):
        _, _, ank, hip, knee = p[side]
        assert ank == pytest.approx((ya, g.ankle_height))
        assert hip == pytest.approx((ya + g.l1 * np.sin(phi), g.ankle_height + g.l1 * np.cos(phi)))
        assert knee == pytest.approx((ya + g.l1 / 2 * np.sin(phi), g.ankle_height + g.l1 / 2 * np.cos(phi)))
    _, _, R = plots.leg_chain({"ankle_roll": phi, "hip_roll": -phi}, 0.0, 0.1, 0.1)
    assert np.allclose(R, np.eye(3))


def test_rear_view_draws_the_pelvis_tilt_of_the_lateral_hip_strategy():
    """The left knee flexed by κ with its ankle and hip pitch κ/2 (the trunk upright): the left hip
    drops to l1 cos(κ/2) and the knee shows; the pelvis between the hips tilts down to the left."""
    g = plots.Geometry()
    kappa = 0.6
    p = plots._frontal_pose(_rear_row(q_left_knee=kappa, q_left_ankle=kappa / 2, q_left_hip=kappa / 2), 0, g, 0.0)
    _, _, ank, hip, knee = p["left"]
    assert hip == pytest.approx((g.hip_half_width, g.ankle_height + g.l1 * np.cos(kappa / 2)))
    assert p["right"][3] == pytest.approx((-g.hip_half_width, g.ankle_height + g.l1))
    _, _, R = plots.leg_chain({"knee": kappa, "ankle": kappa / 2, "hip": kappa / 2}, 0.0, 0.1, 0.1)
    assert np.allclose(R, np.eye(3))


def test_gif_of_a_3d_controller_run(tmp_path):
    """animate() draws the rear view of a result with the 3D plant's columns and per-leg angles."""
    from PIL import Image
    d = frontal_synthetic(t_end=1.0)
    from numpy.lib import recfunctions as rf
    d = rf.append_fields(d, ["foot_roll", "imu_roll"], [np.zeros(len(d)), np.zeros(len(d))], usemask=False)
    out = plots.animate(d, tmp_path / "f.gif", fps=5, progress=False)
    with Image.open(out) as im:
        assert im.n_frames == 6 and im.size == (640, 400)     # two views: side and rear


# ----------------------------------------------------------------------------------------------
# a run of the 3D controller (FMUs)

def test_run_and_plot_of_a_3d_controller_result(tmp_path):
    """`anklehip run side_push_frontal --plots` writes the frontal Fig. 5 with the outer sole edges
    of the 3D plant's robot header, and `anklehip plot` of its CSV redraws it byte for byte (the
    same numbers from the plant FMU); a sagittal controller's 3D run gets none."""
    from anklehip.cli import main
    from anklehip.running.run import run
    out = tmp_path / "o"
    assert main(["run", "side_push_frontal", "--out", str(out), "--plots", "--no-progress"]) == 0
    png = out / "side_push_frontal_fig5_frontal.png"
    assert png.stat().st_size > 10000
    again = tmp_path / "p"
    assert main(["plot", str(out / "side_push_frontal.csv"), "--out", str(again), "--no-progress"]) == 0
    assert (again / png.name).read_bytes() == png.read_bytes()
    from anklehip import figures
    r = run("side_push_frontal")
    fig = figures.frontal_cycle(r)
    edges = sorted(float(ln.get_ydata()[0]) for ln in fig.axes[2].get_lines() if ln.get_linestyle() == ":")
    assert edges == pytest.approx([-1000 * _edge(), 1000 * _edge()], abs=1e-9)
    assert main(["run", "side_push_3d", "--out", str(tmp_path / "s"), "--plots", "--no-progress"]) == 0
    assert not (tmp_path / "s" / "side_push_3d_fig5_frontal.png").exists()
