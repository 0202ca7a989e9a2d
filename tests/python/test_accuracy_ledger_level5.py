"""Level 5's accuracy ledger (docs/validation.md, "The accuracy ledgers (CI)"): `gearmesh accuracy
--settings level5` on the scenes with CalculiX references (sets A and B, set A lead-crowned, the
helical pair, the internal ring, the lightweight body) recomputed against
scenarios/reference/ledger_level5.csv, each signed error inside its band (test_accuracy_ledger.py:
the bands and the regeneration). Slow: the compliance databases are built where the cache lacks
them (set A's gears serve sets A, B and the lead-crowned pair; the ring's and the lightweight
body's about 45 and 55 s more)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gearmesh.accuracy import levels as accuracy, report as accuracy_report
from gearmesh_dev import ledger as accuracy_ledger
from gearmesh.accuracy.reference import read_summary, summary_path
from gearmesh.accuracy.sweep import summarize
from conftest import REPO

pytestmark = pytest.mark.slow

LEDGER = REPO / "scenarios" / "reference" / "ledger_level5.csv"
GATED = ("mean", "pp", "order1", "order2")


@pytest.fixture(scope="module")
def committed():
    return accuracy_report.read_csv(LEDGER)


@pytest.fixture(scope="module")
def recomputed(fmu_path, tmp_path_factory):
    return accuracy_ledger.recompute(LEDGER, fmu_path, tmp_path_factory.mktemp("level5"))


def test_ledger_covers_level5_against_every_reference(committed):
    """Level 5 at every torque of each scene's 2-D and 3-D references, mean, p-p and orders 1-2
    among the quantities."""
    made = accuracy_ledger.provenance(LEDGER)
    assert made["settings"] == "level5"
    assert {r["setting"] for r in committed} == {"L5 s10 c2"}
    cases = {(r["scene"], r["reference"]) for r in committed}
    assert cases == {("paper_setA_3U4U", "2d"), ("paper_setA_3U4U", "3d-whole"),
                     ("paper_setB_P1P2", "2d"), ("paper_setB_P1P2", "3d"),
                     ("paper_setA_lead_crowned", "3d"), ("helical_fe", "3d"),
                     ("internal_ring_fe", "2d"), ("lightweight_vs_solid_fe", "3d-whole")}
    for scene, kind in cases:
        torques = set(read_summary(summary_path(REPO / made["reference"], scene,
                                                "3d" if kind.startswith("3d") else kind)).torques)
        for q in GATED:
            assert {r["torque_Nm"] for r in committed if (r["scene"], r["reference"], r["quantity"])
                    == (scene, kind, q)} == torques, (scene, kind, q)


def test_level5_ledger_holds(committed, recomputed):
    problems = accuracy_ledger.compare(committed, recomputed)
    assert not problems, "level 5's errors left their bands:\n" + "\n".join(problems)


def test_gate_sees_level5_te_1_05_times_as_large(committed, fmu_path, tmp_path, monkeypatch):
    """A level-5 TE 5 % larger at every position (mean, p-p and orders alike) leaves the band
    of every mean, p-p, order 1 and order 2 row (against a model, and against the band where
    the error is outside it)."""
    sweep = accuracy.sweep

    def scaled(*args, **kwargs):
        result = sweep(*args, **kwargs)
        te = {t: 1.05 * np.asarray(v) for t, v in result.te.items()}
        return dataclasses.replace(result, te=te, summary={t: summarize(v) for t, v in te.items()})

    monkeypatch.setattr(accuracy, "sweep", scaled)
    problems = accuracy_ledger.compare(committed, accuracy_ledger.recompute(LEDGER, fmu_path, tmp_path))
    failing = {p.split(")")[0] + ")" for p in problems}
    rows = {str(accuracy_ledger._key(r)) for r in committed if r["quantity"] in GATED}
    assert rows <= failing, f"not caught: {sorted(rows - failing)}"
