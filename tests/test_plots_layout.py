"""Layout of the standard figures (no FMUs needed): the phase legend and the signal legends
never overlap each other, stay inside the figure and hide no data; progress of figures and GIF
frames follows the simulation's rules (a bar on a terminal only, none with progress=False)."""
from __future__ import annotations

import io
import itertools
import sys

import matplotlib.colors
import numpy as np
import pytest

from anklehip.analysis import plots
from anklehip.analysis.compare import read_result_csv
from anklehip.files.paths import repo_root

GOLDEN = repo_root() / "scenarios" / "reference" / "paper_five_pushes.csv"


def synthetic(t_end=3.0, h=0.01):
    """One push cycle with every phase, the hip angle peaking high (where a legend would go)."""
    t = np.arange(0, t_end + h / 2, h)
    names = ("time", "theta_ankle", "theta_hip", "theta_ankle_ref", "theta_hip_ref", "zmp_x", "com_x",
             "fz", "push_force", "phase")
    d = np.zeros(len(t), [(n, float) for n in names])
    bump = np.exp(-((t - 2.6) / 0.3) ** 2)          # late in the window: under an upper-right legend
    d["time"] = t
    d["theta_ankle"], d["theta_hip"] = -0.08 * bump, 0.33 * bump
    d["theta_ankle_ref"], d["theta_hip_ref"] = d["theta_ankle"], d["theta_hip"]
    d["zmp_x"], d["com_x"] = 0.045 * bump, 0.008 * bump
    d["fz"] = 70.2
    d["push_force"] = np.where((t > 0.5) & (t < 2.8), 6.0, 0.0)
    d["phase"] = np.select([t < 1.0, t < 1.6, t < 2.2, t < 2.9], [0, 1, 2, 3], 0)
    return d


def _figures():
    gold = read_result_csv(GOLDEN)
    for name, d in (("golden", gold), ("synthetic", synthetic())):
        yield f"fig5-{name}", lambda d=d: plots.fig5_figure(d, zmp_limits=(0.025, -0.016), title="fig5")
        yield f"overview-{name}", lambda d=d: plots.overview_figure(d, title="overview")
        yield f"fig4-{name}", lambda d=d: plots.fig4_figure(d, title="fig4")


def _frontal():
    from anklehip.analysis.frontal_cycle import frontal_cycle_figure
    from test_frontal_figure import _edge, frontal_synthetic
    yield "fig5-frontal-synthetic", lambda: frontal_cycle_figure(frontal_synthetic(), edge=_edge(), title="frontal")


FIGURES = list(_figures()) + list(_frontal())


def _intersect(a, b) -> bool:
    """Strict overlap of two display-space bounding boxes (touching edges do not count)."""
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


@pytest.fixture(params=FIGURES, ids=[n for n, _ in FIGURES])
def drawn(request):
    fig = request.param[1]()
    fig.canvas.draw()
    yield fig, fig.canvas.get_renderer()
    plots.plt.close(fig)


def test_one_phase_legend_below_the_panels_with_every_phase(drawn):
    fig, r = drawn
    assert len(fig.legends) == 1, "one phase legend for the whole figure"
    leg = fig.legends[0]
    labels = [t.get_text() for t in leg.get_texts()]
    assert labels == ["phase 0 ankle (unshaded)", "phase 1 ankle→hip", "phase 2 hip", "phase 3 hip→ankle"]
    cyan = leg.legend_handles[3].get_facecolor()
    assert np.allclose(cyan[:3], matplotlib.colors.to_rgb(plots.PHASE_COLORS[3]))
    lb = leg.get_window_extent(r)
    for ax in fig.axes:          # outside every panel, including its tick labels
        assert not _intersect(lb, ax.get_tightbbox(r)), ax.get_ylabel()


def test_legends_do_not_overlap_and_stay_in_the_figure(drawn):
    fig, r = drawn
    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    assert len(legends) >= 2          # the phase legend and at least one signal legend
    boxes = [leg.get_window_extent(r) for leg in legends]
    fb = fig.bbox
    for b in boxes:
        assert fb.x0 - 0.5 <= b.x0 and b.x1 <= fb.x1 + 0.5 and fb.y0 - 0.5 <= b.y0 and b.y1 <= fb.y1 + 0.5, b
    for (i, a), (j, b) in itertools.combinations(enumerate(boxes), 2):
        assert not _intersect(a, b), f"legend {i} overlaps legend {j}: {a} / {b}"


def test_signal_legends_hide_no_data(drawn):
    fig, r = drawn
    for ax in fig.axes:
        leg = ax.get_legend()
        if leg is None:
            continue
        lb = leg.get_window_extent(r)
        for line in ax.get_lines():
            xy = line.get_transform().transform(np.column_stack(line.get_data()).astype(float))
            inside = ((xy[:, 0] > lb.x0) & (xy[:, 0] < lb.x1) & (xy[:, 1] > lb.y0) & (xy[:, 1] < lb.y1))
            assert not inside.any(), f"{ax.get_ylabel()}: {line.get_label()} runs under the legend"


# ----------------------------------------------------------------------------------------------
# progress and the GIF

class _Terminal(io.StringIO):
    def isatty(self):
        return True


def test_gif_progress_on_a_terminal_and_the_file_it_wrote(tmp_path, monkeypatch):
    err = _Terminal()
    monkeypatch.setattr(sys, "stderr", err)
    out = plots.animate(synthetic(), tmp_path / "a.gif", fps=10, title="syn")
    text = err.getvalue()
    assert "frame" in text and "GIF a.gif" in text
    assert f"anklehip: wrote {out}" in text


@pytest.mark.parametrize("progress, stream", [(False, _Terminal), (None, io.StringIO)])
def test_no_gif_progress_with_no_progress_or_off_a_terminal(tmp_path, monkeypatch, progress, stream):
    err = stream()
    monkeypatch.setattr(sys, "stderr", err)
    plots.animate(synthetic(), tmp_path / "a.gif", fps=10, progress=progress)
    assert err.getvalue() == ""


def test_gif_frames_and_exact_colours(tmp_path):
    """Every frame is written (3 s at 10 fps: 31 frames, none identical: the clock runs), and the
    one palette keeps the background white and the arrow's orange exact."""
    from PIL import Image, ImageSequence
    out = plots.animate(synthetic(), tmp_path / "a.gif", fps=10, progress=False)
    with Image.open(out) as im:
        assert im.n_frames == 31
        frames = [f.convert("RGB") for f in ImageSequence.Iterator(im)]
    assert frames[0].getpixel((1, 1)) == (255, 255, 255)
    orange = tuple(round(255 * c) for c in matplotlib.colors.to_rgb("tab:orange"))
    assert any(orange in {c for _, c in f.getcolors(1 << 16)} for f in frames[5:25])   # the push arrow


def test_make_figures_progress_bar_and_lines(tmp_path, monkeypatch):
    from anklehip.running.run import make_figures
    err = _Terminal()
    monkeypatch.setattr(sys, "stderr", err)
    files = make_figures("syn", synthetic(), tmp_path)
    assert [f.name for f in files] == ["syn_overview.png", "syn_fig4_joint_angles.png", "syn_fig5_first_cycle.png"]
    text = err.getvalue()
    assert "figures" in text
    for f in files:
        assert f"anklehip: wrote {f}" in text
    err2 = _Terminal()
    monkeypatch.setattr(sys, "stderr", err2)
    make_figures("syn", synthetic(), tmp_path, progress=False)
    assert err2.getvalue() == ""


def test_sweep_figure_has_a_legend_inside_the_figure():
    """sweep.png says what its markers mean (it had no legend): a legend with the three kinds of
    point, inside the figure and clear of the axes."""
    from anklehip.running.sweep import sweep_figure
    rows = [{"variant": v, "peak_force": f, "outcome": "fell" if f > lim else "completed",
             "max_phase": 0 if f < 8 else 3} for v, lim in (("full", 11.0), ("ankle_only", 8.0))
            for f in np.arange(7.0, 12.5, 0.5)]
    fig = sweep_figure(rows, "hip_saves_push: outcome vs peak push force")
    assert _sweep_legend(fig) == [
        "stood, ankle strategy only (phase 0)", "stood, hip strategy (n: highest phase)", "fell"]
    plots.plt.close(fig)


def _sweep_legend(fig) -> list[str]:
    """The texts of sweep_figure's one legend, asserted inside the figure and clear of its one axes."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    (ax,) = fig.axes
    (leg,) = fig.legends
    lb, fb = leg.get_window_extent(r), fig.bbox
    assert fb.x0 <= lb.x0 and lb.x1 <= fb.x1 and fb.y0 <= lb.y0 and lb.y1 <= fb.y1
    assert not _intersect(lb, ax.get_window_extent(r))
    return [t.get_text() for t in leg.get_texts()]


def test_sweep_figure_marks_steps():
    """With the stepping layer's columns, sweep.png colours a run that stepped as the decision surfaces
    do (purple, anklehip.analysis.capability.strategy_of) and its legend says so, still inside the
    figure and clear of the axes."""
    from matplotlib.colors import to_rgba
    from anklehip.running.sweep import sweep_figure
    rows = [{"variant": "stepping", "peak_force": f, "outcome": "fell" if f > 30 else "completed",
             "max_phase": 0 if f < 10 else 2, "steps": 2 if f > 20 else 0, "stepped": int(f > 20)}
            for f in np.arange(4.0, 34.0, 2.0)]
    fig = sweep_figure(rows, "stepping")
    assert _sweep_legend(fig) == [
        "stood, ankle strategy only (phase 0)", "stood, hip strategy (n: highest phase)", "stood, a step", "fell"]
    colours = [tuple(c.get_facecolors()[0]) for c in fig.axes[0].collections]
    stood_stepped = [c for row, c in zip(rows, colours) if row["stepped"] and row["outcome"] == "completed"]
    assert stood_stepped and all(c == to_rgba("tab:purple") for c in stood_stepped)
    plots.plt.close(fig)


def test_polar_capability_map_legend_and_titles_clear_of_the_panels(tmp_path):
    """The polar capability map (anklehip/analysis/capability.py: polar_figure): one polar panel per
    duration, the legend (variants and the three bounds) inside the figure and clear of every panel,
    the panel titles inside the figure."""
    from anklehip.analysis.bounds import HEADER_NAMES
    from anklehip.analysis.capability import polar_figure
    from anklehip.running.sweepfile import load_sweep_file
    from conftest import NOMINAL
    p = tmp_path / "polar.toml"
    p.write_text('scenario = "paper_five_pushes_3d"\n[push]\nrise = 0.05\n[[variant]]\nname = "a"\n[[variant]]\n'
                 'name = "b"\n[grid]\n"push.angle" = "0:330:30"\n"push.force" = [4, 8, 12]\n"push.duration" = [1.0, 0.2]\n')
    sf = load_sweep_file(p)
    rows = [{"variant": v, "push.angle": a, "push.force": f, "push.duration": d,
             "outcome": "completed" if f <= lim + (4 if d < 1 else 0) else "fell"}
            for v, lim in (("a", 8), ("b", 4)) for a in range(0, 360, 30) for f in (4, 8, 12) for d in (1.0, 0.2)]
    params = {k: NOMINAL[m] for k, m in HEADER_NAMES.items()} | {"h_push": 0.335}
    fig = polar_figure(sf, rows, params)
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    panels = [ax for ax in fig.axes if ax.name == "polar"]
    assert len(panels) == 2 and [ax.get_title() for ax in panels] == ["1 s pushes", "0.2 s pushes"]
    (leg,) = fig.legends
    assert [t.get_text() for t in leg.get_texts()][:2] == ["a", "b"] and len(leg.get_texts()) == 5
    lb, fb = leg.get_window_extent(r), fig.bbox
    assert fb.x0 <= lb.x0 and lb.x1 <= fb.x1 and fb.y0 <= lb.y0 and lb.y1 <= fb.y1
    for ax in panels:
        assert not _intersect(lb, ax.get_tightbbox(r))
        tb = ax.title.get_window_extent(r)
        assert fb.y0 <= tb.y0 and tb.y1 <= fb.y1
    plots.plt.close(fig)


def _draw_points(tmp_path, monkeypatch, axes, rows):
    """capability.plot_points on a synthetic two-variant sweep of `axes`: its drawn figures by file
    name, each with its renderer."""
    from pathlib import Path
    from types import SimpleNamespace
    import matplotlib.figure
    from anklehip.analysis import capability
    from anklehip.running.sweep import Variant
    sf = SimpleNamespace(name="syn", axes=axes, ranges={},
                         variants=[Variant("flat_footed", {}, {}), Variant("stepping", {}, {})])
    drawn = {}
    real_savefig = matplotlib.figure.Figure.savefig

    def keep(fig, path, *a, **k):
        fig.canvas.draw()
        drawn[Path(path).name] = (fig, fig.canvas.get_renderer())
        return real_savefig(fig, path, *a, **k)
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep)
    capability.plot_points(sf, rows, tmp_path)
    return drawn


def test_sweep_points_figures_share_one_x_label(tmp_path, monkeypatch):
    """The point figures of a two-key sweep file (anklehip/analysis/capability.py: plot_points) have
    one x label under all the variants' panels, inside the figure and clear of every panel (each
    panel had its own, and side by side the long ones ran into each other)."""
    rows = [{"variant": v, "push.angle": a, "push.force": f, "outcome": "completed" if f < 20 else "fell",
             "max_phase": 1, "stepped": int(v == "stepping" and f >= 20), "peak_zmp": 0.05, "time_to_recover": 1.0}
            for v in ("flat_footed", "stepping") for a in (0, 90, 180) for f in (10, 20)]
    fig, r = _draw_points(tmp_path, monkeypatch, {"push.angle": [0, 90, 180], "push.force": [10, 20]},
                          rows)["points_outcome.png"]
    assert [ax.get_xlabel() for ax in fig.axes] == ["", ""]
    label = fig._supxlabel
    assert label is not None and label.get_text().startswith("push direction [deg]")
    lb, fb = label.get_window_extent(r), fig.bbox
    assert fb.x0 <= lb.x0 and lb.x1 <= fb.x1 and fb.y0 <= lb.y0
    assert not any(_intersect(lb, ax.get_window_extent(r)) for ax in fig.axes)


def test_sweep_points_log_axis_labels_are_plain_and_apart(tmp_path, monkeypatch):
    """A key spanning 20 times or more is drawn on a log axis (stepping_3d's forces, 2-50 N): its tick
    labels are plain numbers (the default log formatter labelled the minor ticks "2x10^0 3x10^0 ..."
    and they ran into each other) and no two labels of a panel overlap."""
    forces = [2, 5, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30, 32, 36, 40, 44, 50]
    rows = [{"variant": v, "push.duration": d, "push.force": f, "outcome": "completed" if f < 20 else "fell",
             "max_phase": 1, "stepped": 0, "peak_zmp": 0.05, "time_to_recover": 1.0}
            for v in ("flat_footed", "stepping") for d in (0.1, 0.2, 0.5, 1.0) for f in forces]
    for name, (fig, r) in _draw_points(tmp_path, monkeypatch, {"push.force": forces,
                                                               "push.duration": [0.1, 0.2, 0.5, 1.0]}, rows).items():
        for ax in fig.axes[:2]:
            assert ax.get_xscale() == "log", name
            labels = [t for t in ax.get_xticklabels() + ax.get_xticklabels(minor=True)
                      if t.get_visible() and t.get_text() and _intersect(t.get_window_extent(r), ax.bbox.expanded(1.0, 2.0))]
            texts = [t.get_text() for t in labels]
            assert texts and all("times" not in x and "^" not in x for x in texts), (name, texts)
            boxes = [t.get_window_extent(r) for t in labels]
            assert not any(_intersect(a, b) for i, a in enumerate(boxes) for b in boxes[i + 1:]), (name, texts)
