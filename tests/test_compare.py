"""The CSV comparator (FMI cross-check band via fmpy.util.validate_signal + optional tube)."""
import json

import numpy as np
import pytest
from fmpy.util import read_csv, write_csv

from anklehip.cli import main
from anklehip.analysis.compare import CompareError, compare, comparison_figure

T = np.linspace(0.0, 10.0, 2001)


def make(t, **cols):
    dt = [("time", float)] + [(k, np.asarray(v).dtype) for k, v in cols.items()]
    a = np.zeros(len(t), dtype=dt)
    a["time"] = t
    for k, v in cols.items():
        a[k] = v
    return a


def ref_signals(t):
    return make(t, y=np.sin(t) + 0.2 * t, ramp=np.clip(t - 3, 0, 2), phase=(t > 5).astype(np.int32) * 2)


def test_identical_passes(tmp_path):
    ref = ref_signals(T)
    write_csv(tmp_path / "ref.csv", ref)
    write_csv(tmp_path / "res.csv", ref)
    rep = compare(tmp_path / "res.csv", tmp_path / "ref.csv", abs_tol=0.0)
    assert rep.passed, rep.text()
    assert all(s.max_dev == 0 for s in rep.signals)
    assert main(["compare", str(tmp_path / "res.csv"), str(tmp_path / "ref.csv")]) == 0


def test_offset_beyond_tolerance_fails_at_the_right_time():
    ref = ref_signals(T)
    res = ref.copy()
    res["y"] = np.where(T >= 6.0, res["y"] + 1.0, res["y"])      # the band is 0.1 x range (~0.35)
    rep = compare(res, ref)
    s = {x.name: x for x in rep.signals}
    assert not rep.passed and s["ramp"].passed and s["phase"].passed
    y = s["y"]
    assert not y.passed
    assert 6.0 <= y.first_outside <= 6.0 + 0.2       # band half-width: 20 of 1000 samples over 10 s
    assert y.max_dev == pytest.approx(1.0)
    assert y.max_dev_time >= 6.0


def test_small_offset_inside_band_passes_but_fails_strict_tube():
    ref = ref_signals(T)
    res = ref.copy()
    res["y"] = res["y"] + 0.01
    assert compare(res, ref).passed
    rep = compare(res, ref, abs_tol=1e-3)
    y = [s for s in rep.signals if s.name == "y"][0]
    assert not y.passed and y.first_outside == pytest.approx(0.0)


def test_time_shift_fails_at_the_right_time():
    ref = ref_signals(T)
    res = make(T, y=ref["y"], ramp=ref["ramp"], phase=((T > 5.5) * 2).astype(np.int32))
    rep = compare(res, ref)
    ph = [s for s in rep.signals if s.name == "phase"][0]
    assert not ph.passed and ph.discrete
    # a discrete signal is compared exactly (no horizontal band tolerance): every sample in (5, 5.5] differs
    assert ph.first_outside == T[T > 5][0]
    assert ph.n_outside == np.count_nonzero((T > 5) & (T <= 5.5))
    assert "samples differ" in ph.line()


def test_resampled_equal_signal_passes():
    ref = ref_signals(T)
    t2 = np.sort(np.concatenate([np.linspace(0, 10, 777), [2.5, 7.25]]))
    res = ref_signals(t2)
    rep = compare(res, ref, abs_tol=2e-3)
    assert rep.passed, rep.text()


def test_missing_column_is_a_clear_error(tmp_path):
    ref = ref_signals(T)
    res = make(T, y=ref["y"], phase=ref["phase"])
    with pytest.raises(CompareError, match=r"result .*missing column\(s\) ramp"):
        compare(res, ref)
    write_csv(tmp_path / "ref.csv", ref)
    write_csv(tmp_path / "res.csv", res)
    assert main(["compare", str(tmp_path / "res.csv"), str(tmp_path / "ref.csv")]) == 2
    # asking only for present columns works
    assert compare(res, ref, columns=["y", "phase"]).passed


def test_extra_columns_are_noted():
    ref = ref_signals(T)
    res = make(T, y=ref["y"], ramp=ref["ramp"], phase=ref["phase"], extra=np.ones(len(T)))
    rep = compare(res, ref)
    assert rep.passed and rep.extra_columns == ["extra"] and "extra" in rep.notes[0]


def test_nan_in_result_fails_with_time():
    ref = ref_signals(T)
    res = ref.copy()
    res["y"][1200] = np.nan
    rep = compare(res, ref)
    y = [s for s in rep.signals if s.name == "y"][0]
    assert not y.passed and "NaN" in y.message and y.first_outside == pytest.approx(T[1200])


def test_nan_in_reference_fails_clearly():
    ref = ref_signals(T)
    res = ref.copy()
    ref["ramp"][5] = np.nan
    rep = compare(res, ref)
    r = [s for s in rep.signals if s.name == "ramp"][0]
    assert not r.passed and "reference has NaN" in r.message


def test_short_result_fails_coverage():
    ref = ref_signals(T)
    res = ref[T <= 7.0]
    rep = compare(res, ref)
    assert not rep.passed and "covers" in rep.failed[0].message
    assert compare(res, ref, require_coverage=False).passed


def test_empty_and_header_only_files(tmp_path):
    (tmp_path / "empty.csv").write_text("")
    (tmp_path / "head.csv").write_text('"time","y"\n')
    write_csv(tmp_path / "ref.csv", ref_signals(T))
    with pytest.raises(CompareError, match="empty file"):
        compare(tmp_path / "empty.csv", tmp_path / "ref.csv")
    with pytest.raises(CompareError, match="no data rows"):
        compare(tmp_path / "head.csv", tmp_path / "ref.csv")
    with pytest.raises(CompareError, match="no such file"):
        compare(tmp_path / "nope.csv", tmp_path / "ref.csv")


def test_time_going_backwards_is_an_error():
    ref = ref_signals(T)
    res = ref.copy()
    res["time"][10] = 0.0
    with pytest.raises(CompareError, match="time goes backwards at row"):
        compare(res, ref)


def test_plot_of_failed_signals(tmp_path):
    ref = ref_signals(T)
    res = ref.copy()
    res["y"] = res["y"] + 2
    write_csv(tmp_path / "ref.csv", ref)
    write_csv(tmp_path / "res.csv", res)
    png = tmp_path / "failed.png"
    rc = main(["compare", str(tmp_path / "res.csv"), str(tmp_path / "ref.csv"), "--plot", str(png),
               "--json", str(tmp_path / "r.json")])
    assert rc == 1 and png.stat().st_size > 1000 and (tmp_path / "r.json").is_file()


def test_csv_layout_round_trip(tmp_path):
    from anklehip.files.output import atomic_write_csv
    ref = ref_signals(T)
    atomic_write_csv(tmp_path / "a.csv", ref)
    back = read_csv(tmp_path / "a.csv")
    assert back.dtype.names == ref.dtype.names
    assert np.array_equal(back["y"], ref["y"]) and np.array_equal(back["phase"], ref["phase"])
    assert (tmp_path / "a.csv").read_text().splitlines()[0] == '"time","y","ramp","phase"'
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


def test_band_floor_for_nearly_constant_signals():
    ref = make(T, fz=70.2 + 0.01 * np.sin(T))
    res = ref.copy()
    res["fz"] = res["fz"] + 0.01          # range 0.02 -> band +-0.002: fails without a floor
    assert not compare(res, ref).passed
    assert compare(res, ref, band_floor=0.05).passed
    assert compare(res, ref, tolerances={"fz": {"band_floor": 0.05}}).passed
    res["fz"][1500:] += 1.0
    rep = compare(res, ref, band_floor=0.05)
    assert not rep.passed and rep.signals[0].first_outside == pytest.approx(T[1500])


def test_non_numeric_cell_names_line_and_column(tmp_path):
    write_csv(tmp_path / "ref.csv", ref_signals(T))
    lines = (tmp_path / "ref.csv").read_text().splitlines()
    cells = lines[5].split(",")
    cells[2] = "oops"
    lines[5] = ",".join(cells)
    (tmp_path / "res.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(CompareError, match=r"result .*res.csv: not a valid result CSV: line 6, column 'ramp': "
                                           r"value 'oops' is not a number"):
        compare(tmp_path / "res.csv", tmp_path / "ref.csv")


def test_reference_without_time_column_is_a_clear_error(tmp_path, capsys):
    write_csv(tmp_path / "res.csv", ref_signals(T))
    (tmp_path / "ref.csv").write_text('"y","ramp"\n1,2\n3,4\n')
    with pytest.raises(CompareError, match=r"reference .*ref.csv: the first column must be the time column "
                                           r"'time'.*got 'y'"):
        compare(tmp_path / "res.csv", tmp_path / "ref.csv")
    assert main(["compare", str(tmp_path / "res.csv"), str(tmp_path / "ref.csv")]) == 2
    assert "first column must be the time column" in capsys.readouterr().err


def test_tolerance_for_a_signal_that_is_not_compared_is_an_error():
    ref = ref_signals(T)
    with pytest.raises(CompareError, match=r"tolerances given for signal\(s\) that are not compared: yy"):
        compare(ref, ref, tolerances={"yy": {"abs_tol": 1.0}})


# --- `compare --plot` writes also when all pass; the plot shows the verdict's band, tube and failures;
# --- integer signals are compared exactly

def _png(path):
    return path.is_file() and path.stat().st_size > 1000 and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plot_is_written_when_every_signal_passes(tmp_path, capsys):
    write_csv(tmp_path / "ref.csv", ref_signals(T))
    write_csv(tmp_path / "res.csv", ref_signals(T))
    png = tmp_path / "sub" / "pass.png"
    assert main(["compare", str(tmp_path / "res.csv"), str(tmp_path / "ref.csv"), "--plot", str(png)]) == 0
    assert _png(png)
    out = capsys.readouterr().out
    assert f"plot of all compared signals (all passed): {png}" in out


@pytest.fixture
def saved_figures(monkeypatch):
    """The matplotlib figures that are saved (to inspect what a plot draws)."""
    from matplotlib.figure import Figure
    figs, savefig = [], Figure.savefig

    def spy(self, *args, **kwargs):
        figs.append(self)
        return savefig(self, *args, **kwargs)
    monkeypatch.setattr(Figure, "savefig", spy)
    return figs


def _marked_points(ax):
    """(x, y) of every marker-only line of an axis: the samples the plot marks as failing."""
    pts = [np.column_stack([ln.get_xdata(), ln.get_ydata()]) for ln in ax.get_lines() if ln.get_linestyle() == "None"]
    return np.concatenate(pts) if pts else np.zeros((0, 2))


def test_plot_draws_the_tube_and_the_failures_of_a_strict_abs_tol(tmp_path, saved_figures, capsys):
    ref = ref_signals(T)
    res = ref.copy()
    res["y"] = np.where(T >= 6.0, res["y"] + 0.01, res["y"])    # inside the default band (~0.35)
    write_csv(tmp_path / "ref.csv", ref)
    write_csv(tmp_path / "res.csv", res)
    png = tmp_path / "strict.png"
    rc = main(["compare", str(tmp_path / "res.csv"), str(tmp_path / "ref.csv"), "--abs-tol", "1e-3",
               "--plot", str(png), "--json", str(tmp_path / "r.json")])
    assert rc == 1 and _png(png)
    assert compare(res, ref).passed                  # the failure comes from the tube alone
    (fig,) = saved_figures
    (ax,) = [ax for ax in fig.axes if ax.get_ylabel() == "y"]
    assert [ax.get_ylabel() for ax in fig.axes] == ["y"]       # only the failed signal
    pts = _marked_points(ax)
    # exactly the samples that the verdict counts: t >= 6, where |dev| = 0.01 > 1e-3
    assert np.array_equal(pts[:, 0], T[T >= 6.0]) and np.allclose(pts[:, 1], res["y"][T >= 6.0])
    assert json.loads((tmp_path / "r.json").read_text())["signals"]["y"]["n_outside"] == len(pts)
    # the tube is drawn: +-1e-3 around the reference
    (tube,) = [c for c in ax.collections if "tube" in c.get_label()]
    ys = np.concatenate([path.vertices[:, 1] for path in tube.get_paths()])
    assert np.ptp(ys) == pytest.approx(np.ptp(ref["y"]) + 2e-3, rel=1e-6)


def test_plot_library_marks_exactly_the_verdicts_samples():
    ref = ref_signals(T)
    res = ref.copy()
    res["y"][[100, 700]] += 0.05
    res["phase"][-1] = 5
    rep = compare(res, ref, abs_tol=0.01)
    fig = comparison_figure(rep)
    axes = {ax.get_ylabel(): ax for ax in fig.axes}
    assert sorted(axes) == ["phase", "y"]
    assert np.array_equal(_marked_points(axes["y"])[:, 0], T[[100, 700]])
    assert np.array_equal(_marked_points(axes["phase"])[:, 0], T[-1:])
    assert {ax.get_ylabel() for ax in comparison_figure(compare(ref, ref)).axes} == {"y", "ramp", "phase"}


def phase_ref(t):
    return make(t, y=np.sin(t), phase=np.where(t < 5.0, 0, 3).astype(np.int32))


@pytest.mark.parametrize("where", ["first sample", "last sample", "40 ms after the switch"])
def test_integer_signal_off_by_3_fails(tmp_path, capsys, where):
    ref = phase_ref(T)
    res = ref.copy()
    bad = {"first sample": T == T[0], "last sample": T == T[-1],
           "40 ms after the switch": (T >= 5.0) & (T < 5.04)}[where]
    res["phase"] = np.where(bad, res["phase"] - 3 if where.startswith("40") else res["phase"] + 3, res["phase"])
    assert np.max(np.abs(res["phase"] - ref["phase"])) == 3
    write_csv(tmp_path / "ref.csv", ref)
    write_csv(tmp_path / "res.csv", res)
    rc = main(["compare", str(tmp_path / "res.csv"), str(tmp_path / "ref.csv"), "--json", str(tmp_path / "r.json")])
    out = capsys.readouterr().out
    assert rc == 1, out
    n, t0 = np.count_nonzero(bad), T[bad][0]
    assert "[FAIL] phase" in out and f"{n}/{len(T)} samples differ, first at t={t0:.4f}" in out
    assert "[PASS] y" in out
    ph = json.loads((tmp_path / "r.json").read_text())["signals"]["phase"]
    assert ph["discrete"] and ph["n_outside"] == n and ph["first_outside"] == t0 and ph["max_dev"] == 3
    # tolerances do not loosen the exact rule
    assert not compare(res, ref, dy=10.0, abs_tol=5.0, band_floor=5.0).passed


def test_integer_signal_on_another_time_grid():
    """Between two reference samples a discrete result may take either's value (a switch in between),
    never another value."""
    ref = phase_ref(T)                                  # samples every 5 ms: 0 at 4.995, 3 from 5.000
    t = np.linspace(0.0, 10.0, 10001)                   # every 1 ms
    res = make(t, y=np.sin(t), phase=np.where(t < 4.997, 0, 3).astype(np.int32))   # switch in between
    rep = compare(res, ref)
    assert rep.passed, rep.text()
    res["phase"][4996] = 1                              # t = 4.996: the reference is 0 or 3 around it
    ph = compare(res, ref).signals[1]
    assert not ph.passed and ph.n_outside == 1 and ph.first_outside == pytest.approx(4.996)
    res["phase"][4996] = 0
    res["phase"][5000] = 0                              # t = 5.000 is a reference sample: 3 exactly
    assert compare(res, ref).signals[1].first_outside == pytest.approx(5.0)


# --- references FMPy's band would loop on (the reliability issue, item 5), progress, units and layout

def _cli(args, timeout=60):
    """`anklehip ARGS` in a subprocess with a time limit: a hang fails the test instead of the suite."""
    import subprocess
    import sys
    return subprocess.run([sys.executable, "-m", "anklehip.cli", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout)


@pytest.mark.parametrize("t0", [1024.0, 4096.0, 1e5])
def test_repeated_reference_time_stamps_late_in_a_run_are_compared(tmp_path, t0):
    """validate_signal adds 1e-13 to a repeated time until it is larger: below one ULP (t >= 1024 s)
    that never ends. The comparison moves each repeat one ULP on instead, and says so."""
    t = t0 + np.linspace(0.0, 10.0, 1001)
    t = np.insert(t, 500, t[500])                 # an event: two rows at one time
    y = np.sin(t - t0)
    write_csv(tmp_path / "ref.csv", make(t, y=y))
    write_csv(tmp_path / "res.csv", make(t, y=y))
    r = _cli(["compare", tmp_path / "res.csv", tmp_path / "ref.csv", "--no-progress"])
    assert r.returncode == 0, r.stderr
    assert "the reference repeats 1 time stamp(s)" in r.stdout and "PASS: 0 of 1 signals failed" in r.stdout


@pytest.mark.parametrize("t0", [0.0, 1e5])
def test_a_reference_whose_time_does_not_advance_is_refused(tmp_path, t0):
    t = np.full(50, t0)
    write_csv(tmp_path / "ref.csv", make(t, y=np.arange(50.0)))
    write_csv(tmp_path / "res.csv", make(np.linspace(t0, t0 + 1, 50), y=np.arange(50.0)))
    r = _cli(["compare", tmp_path / "res.csv", tmp_path / "ref.csv"])
    assert r.returncode == 2 and "the time column does not advance" in r.stderr and f"t = {t0:g} s in all 50" \
        in r.stderr, r.stderr


def test_too_many_rows_at_one_time_are_refused(tmp_path):
    t = np.concatenate([np.full(1500, 2000.0), np.linspace(2001.0, 2010.0, 100)])
    write_csv(tmp_path / "ref.csv", make(t, y=np.zeros(len(t))))
    r = _cli(["compare", tmp_path / "ref.csv", tmp_path / "ref.csv"])
    assert r.returncode == 2 and "more than 1000 rows at one time stamp (from row 2, t = 2000 s)" in r.stderr, r.stderr


def test_compare_shows_progress(tmp_path, capsys):
    ref = ref_signals(T)
    rep = compare(ref, ref, progress=True)
    err = capsys.readouterr().err
    # reading both files, then each signal by name
    assert rep.passed and "compare:" in err and "reading result" in err, err
    assert all(f", {name} " in err for name in ("y", "ramp", "phase")), err
    compare(ref, ref, progress=False)
    assert capsys.readouterr().err == ""
    write_csv(tmp_path / "ref.csv", ref)
    assert main(["compare", str(tmp_path / "ref.csv"), str(tmp_path / "ref.csv"), "--no-progress"]) == 0
    assert capsys.readouterr().err == ""


def _bbox(artist, fig):
    return artist.get_window_extent(fig.canvas.get_renderer())


def test_comparison_figure_units_title_and_headers(fmu_dir):
    """The y axes carry the signals' units (from the FMUs' variables), the figure's title does not
    overprint the first panel, and every panel's header (the verdict line, wrapped) lies inside the
    figure."""
    t = np.linspace(0, 5, 501)
    ref = make(t, theta_hip=0.3 * np.sin(t), zmp_x=0.01 * np.cos(t), phase=(t > 2).astype(np.int32))
    res = ref.copy()
    res["theta_hip"] = res["theta_hip"] + np.where(t > 3, 0.2, 0.0)
    res["zmp_x"] = res["zmp_x"] + np.where(t > 1, 0.01, 0.0)
    rep = compare(res, ref, result_label="a result with a rather long name/" * 4,
                  reference_label="the reference/" * 6)
    assert rep.units == {"theta_hip": "rad", "zmp_x": "m", "phase": ""}
    fig = comparison_figure(rep)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    FigureCanvasAgg(fig).draw()
    axes = fig.axes
    assert [ax.get_ylabel() for ax in axes] == ["theta_hip [rad]", "zmp_x [m]"]
    box = fig.bbox
    sup = _bbox(fig._suptitle, fig)
    for ax in axes:
        title = _bbox(ax.title, fig)
        assert title.x0 >= box.x0 - 1 and title.x1 <= box.x1 + 1 and title.y1 <= box.y1 + 1, ax.title.get_text()
        assert not sup.overlaps(title) and not sup.overlaps(_bbox(ax, fig))


@pytest.mark.parametrize("cell", [1e30, -1e12, 4e8])
def test_one_absurd_reference_cell_fails_instead_of_widening_the_band(tmp_path, cell):
    """FMPy's band is dy times the signal's range: one 1e30 cell in the reference made it 1e29 high
    and garbage passed (issue 33). Such an isolated cell fails the signal, naming it."""
    ref = ref_signals(T)
    ref["y"][700] = cell
    garbage = ref_signals(T)
    garbage["y"] = 1e5
    rep = compare(garbage, ref)
    y = next(s for s in rep.signals if s.name == "y")
    assert not y.passed and f"isolated value {cell:.6g} at t={T[700]:.6g} s" in y.message, y.message
    assert "corrupt cell" in y.message
    assert next(s for s in rep.signals if s.name == "ramp").passed   # the other signals are compared as ever
    write_csv(tmp_path / "ref.csv", ref)
    write_csv(tmp_path / "res.csv", garbage)
    assert main(["compare", str(tmp_path / "res.csv"), str(tmp_path / "ref.csv"), "--no-progress"]) == 1


def test_a_genuine_spike_is_compared_as_usual():
    """A sharp but physical peak (an impact: 300 times the rest of the signal) is not an outlier."""
    y = 0.01 * np.sin(T)
    y[1000] = 3.0
    ref = make(T, y=y)
    rep = compare(ref, ref)
    assert rep.passed, rep.text()
