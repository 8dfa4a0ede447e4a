"""The CSV comparator (FMI cross-check band via fmpy.util.validate_signal + optional tube)."""
import numpy as np
import pytest
from fmpy.util import read_csv, write_csv

from anklehip.cli import main
from anklehip.compare import CompareError, compare

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
    # the band allows ~0.1 s of shift; the first sample outside is just after 5.1 s
    assert 5.05 < ph.first_outside < 5.2


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
    from anklehip.results import atomic_write_csv
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
