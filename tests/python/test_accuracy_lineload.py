"""The peak line load of `gearmesh accuracy` against the 3-D reference's line load across the face
(<scene>.reference_fe3d.lineload.csv, reference_fe/README.md "3-D line load"): the reader, the
error row, and the product side (mesh.max_line_load collected by the sweep)."""
from __future__ import annotations

import numpy as np
import pytest

from gearmesh.accuracy import report as accuracy_report
from gearmesh.accuracy.reference import (PEAK_LINE_LOAD, ReferenceError, lineload_path, peak_line_load_error,
                                         read_lineload)
from gearmesh.accuracy.sweep import sweep
from gearmesh.scene import load_scene
from gearmesh.scene_fmu import build_scene_fmu
from conftest import REPO

FIXTURES = REPO / "tests" / "python" / "fixtures" / "accuracy"
# scene "fx", 150 N m, 8 positions, 2 and 1 bins over a 20 mm face, teeth 0 and 56: tooth 0
# alone at positions 0-3 (1000 N, 500 N per 10 mm bin), the load shared at 4-7 and skewed at
# position 5 (tooth 0: 600 N, 40 / 60 % over the bins)
FIXTURE = FIXTURES / "fx.reference_fe3d.lineload.csv"


def test_reader_gives_the_peak_per_position_and_bin_count():
    peaks = read_lineload(FIXTURE, 8)
    assert sorted(peaks) == [(1, 150.0), (2, 150.0)]
    assert peaks[(2, 150.0)] == pytest.approx([5e4] * 4 + [2.5e4, 3.6e4, 2.5e4, 2.5e4])
    assert peaks[(1, 150.0)] == pytest.approx([5e4] * 4 + [2.5e4, 3e4, 2.5e4, 2.5e4])
    assert read_lineload(FIXTURE, 20) == {}                    # rows of another n: none
    assert read_lineload(FIXTURES / "missing.csv", 8) == {}
    assert lineload_path(FIXTURES, "fx") == FIXTURE


def test_reader_refuses_incomplete_or_bad_files(tmp_path):
    lines = FIXTURE.read_text().splitlines()
    head, body = lines[:2], lines[2:]
    cases = {
        r"2 bins at 150 N m has positions \[0, 1, 2, 4, 5, 6, 7\]; required: 0..7":
            [r for r in body if not (",3,8," in r and ",2,0.01," in r)],
        "allowed: finite, >= 0": [body[0].rsplit(",", 1)[0] + ",-1.0"] + body[1:],
        r"position\(s\) \[0\]: no contact force":
            [r.rsplit(",", 1)[0] + ",0.0" if ",150,0,8," in r else r for r in body],
        "row 2: could not convert": [body[0].replace(",150,", ",x,")] + body[1:],
    }
    for message, rows in cases.items():
        path = tmp_path / "x.reference_fe3d.lineload.csv"
        path.write_text("\n".join(head + rows) + "\n")
        with pytest.raises(ReferenceError, match=message):
            read_lineload(path, 8)
    path.write_text("\n".join([head[1].replace("line_load_N_per_m", "q")] + body) + "\n")
    with pytest.raises(ReferenceError, match="line_load_N_per_m"):
        read_lineload(path, 8)


def test_error_compares_like_with_like():
    """The product's largest over the positions against the reference's largest at as many bins
    as the setting's slices; nothing for a slice count or torque the reference lacks."""
    peaks = read_lineload(FIXTURE, 8)
    row = peak_line_load_error(peaks, 150.0, 2, [5.5e4] + [1.0] * 7)
    assert row["quantity"] == PEAK_LINE_LOAD and row["unit"] == "N/m"
    assert (row["product"], row["fe3d"]) == (5.5e4, 5e4)
    assert row["band_error"] == pytest.approx(0.1) and row["error_fe3d"] == row["band_error"]
    row = peak_line_load_error(peaks, 150.0, 1, [1.0] * 7 + [4.5e4])
    assert row["fe3d"] == 5e4 and row["band_error"] == pytest.approx(-0.1)
    assert peak_line_load_error(peaks, 150.0, 10, [1.0] * 8) is None
    assert peak_line_load_error(peaks, 350.0, 2, [1.0] * 8) is None
    assert PEAK_LINE_LOAD in accuracy_report.SHOWN


def test_shown_not_scored():
    """A setting's 3-D score ignores the peak line load (shown only: docs/validation.md)."""
    rows = [{"scene": "s", "reference": "3d", "setting": "L4 s10", "level": 4, "quantity": q,
             "band_error": e, **{k: 1.0 for k in accuracy_report.TIME_COLUMNS}}
            for q, e in (("pp", 0.05), (PEAK_LINE_LOAD, -0.5))]
    entry, = accuracy_report.per_setting(rows)
    assert entry[PEAK_LINE_LOAD] == -0.5 and entry["score"] == pytest.approx(0.05)


def test_sweep_collects_the_largest_slice_line_load(fmu_path, tmp_path):
    """mesh.max_line_load over the positions: with 5 um of lead crowning the largest slice (of
    10) carries more than the most loaded pair's face average and less than the whole normal
    force on one slice."""
    scene = load_scene(REPO / "scenarios" / "paper_setA_lead_crowned.toml")
    values = {**scene.parameters, "model.stiffness": 4, "model.slices": 10}
    fmu = build_scene_fmu(fmu_path, values, {}, tmp_path / "c.fmu")
    result = sweep(fmu, {}, [150.0], 8, repeats=1)
    peak, pair = result.max_line_load[150.0], result.pair_line_load[150.0]
    assert peak.shape == (8,)
    assert np.all(peak > 1.05 * pair), (peak, pair)
    b = 0.023
    assert np.all(peak < 150.0 / (0.0026 * 57 * np.cos(np.radians(20)) / 2) / (b / 10))
