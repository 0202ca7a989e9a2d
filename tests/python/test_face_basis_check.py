"""`gearmesh-dev face-basis-check` (tools/gearmesh_dev/face_basis_check.py): its arithmetic on
hand-made sweeps and its option errors. The comparison itself runs the FMU over the level-5
ledger's scenes (minutes per scene) and is run on purpose, not here; its figures are in
docs/model.md."""
from __future__ import annotations

import math

import pytest

from gearmesh_dev import face_basis_check as fbc

FULL = {"mean": 8.0e-6, "pp": -4.0e-6, "order1": 1.0e-6, "order2": 0.0, "order3": 2.0e-8}


def test_relative_changes_are_against_the_full_solves_magnitude():
    reduced = {"mean": 8.004e-6, "pp": -4.002e-6, "order1": 0.999e-6, "order2": 1e-9, "order3": 2.1e-8}
    c = fbc.relative_changes(FULL, reduced)
    assert c["mean"] == pytest.approx(5e-4)
    assert c["pp"] == pytest.approx(-5e-4)  # -4.002 against -4.000: 0.05 % more negative
    assert c["order1"] == pytest.approx(-1e-3)
    assert math.isnan(c["order2"])  # nothing to compare with
    assert c["order3"] == pytest.approx(0.05)


def test_largest_picks_the_largest_magnitude_per_k_and_says_where():
    rows = [{"scene": "a", "torque": 50.0, "shapes": 3, "changes": {**dict.fromkeys(fbc.QUANTITIES, 1e-4),
                                                                   "order3": -7e-4}},
            {"scene": "b", "torque": 350.0, "shapes": 3, "changes": {**dict.fromkeys(fbc.QUANTITIES, 2e-4),
                                                                    "order2": float("nan")}},
            {"scene": "b", "torque": 350.0, "shapes": 2, "changes": {**dict.fromkeys(fbc.QUANTITIES, 0.0),
                                                                    "pp": 8e-3}}]
    best = fbc.largest(rows)
    assert (best[3]["scene"], best[3]["quantity"], best[3]["change"]) == ("a", "order3", 7e-4)
    assert (best[2]["scene"], best[2]["torque"], best[2]["quantity"]) == ("b", 350.0, "pp")
    text = fbc.table(rows)
    assert "| 2 | 0.8 % (p-p) | b, 350 N·m |" in text
    assert "| 3 | 0.07 % (order 3) | a, 50 N·m |" in text


@pytest.mark.parametrize("shapes", ["0", "9", "2,x", ""])
def test_shape_counts_outside_1_to_8_are_refused(shapes, capsys):
    with pytest.raises(SystemExit) as exc:
        fbc.main(["--shapes", shapes])
    assert exc.value.code == 2
    assert "--shapes" in capsys.readouterr().err
