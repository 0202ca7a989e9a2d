"""The stability suite's CI subset (`gearmesh stability --quick`, docs/stability.md): every run
whose outcome the suite expects (gearmesh.stability.expected) comes out that way — the plain
element under the explicit master diverges at 1e-3 and 1e-2 s and passes at 1e-5 s, the implicit
master passes at 1e-5 s, the large-step mode passes at every step — and the large-step mode is
stable (finite, no error, converged, energy balance) on every quick case at 1e-3 and 1e-2 s.
The judgements themselves are checked on made-up runs, so that a judgement that could not fail
would show here.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from gearmesh.stability import suite as stability
from gearmesh.fmu_driver import GearMeshFMU
from gearmesh.stability.cases import SETTLE, select
from gearmesh.stability.runs import Run, chain_plant, converged_te, cut_reference_te, prepare


@pytest.fixture(scope="module")
def quick_rows(fmu_path, tmp_path_factory):
    cases = select(None, quick=True)
    rows = stability.run_suite(fmu_path, cases, stability.parse_modes(None),
                               stability.QUICK_STEPS, progress=False)
    stability.write_outputs(rows, tmp_path_factory.mktemp("stability"))
    return rows


def test_quick_subset_has_every_mode_and_step(quick_rows):
    assert len(select(None, quick=True)) >= 6
    assert {(r.mode, r.step) for r in quick_rows} == {
        (m, h) for m in stability.parse_modes(None) for h in stability.QUICK_STEPS}


def test_every_expected_outcome_holds(quick_rows):
    asserted = [r for r in quick_rows if r.expected is not None]
    assert len(asserted) >= 40
    wrong = [f"{r.case} {r.mode} {r.step:g}: {r.passed} (expected {r.expected}) {r.failed}"
             for r in asserted if r.passed != r.expected]
    assert not wrong, "\n".join(wrong)


def test_explicit_master_diverges_at_large_steps(quick_rows):
    big = [r for r in quick_rows if r.mode == "explicit" and r.step >= 1e-3
           and r.case not in ("free_in_backlash", "zero_load_contact")]
    assert big and not any(r.stable for r in big)


def test_large_step_mode_stable_at_large_steps(quick_rows):
    rows = [r for r in quick_rows if r.mode.startswith("large_step") and r.step >= 1e-3
            and r.stable is not None]
    assert len(rows) >= 2 * len(select(None, quick=True))
    bad = [f"{r.case} {r.mode} {r.step:g}: {r.failed}" for r in rows if not r.stable]
    assert not bad, "\n".join(bad)


def test_large_step_mode_passes_at_large_steps(quick_rows):
    """Every judgement, TE against the converged references included, on every quick case at
    1e-3 and 1e-2 s, through simulate_fmu (the rollback case is not applicable to its fixed
    steps, so n/a there) and in the chain (where the undamped case, free gears without the
    chain's drive shaft, is n/a)."""
    rows = [r for r in quick_rows if r.mode.startswith("large_step") and r.step >= 1e-3
            and r.passed is not None]
    quick = select(None, quick=True)
    runs = sum(len(c.modes) if c.modes else 2 for c in quick) - sum(1 for c in quick if c.rollback)
    assert len(rows) >= 2 * runs
    bad = [f"{r.case} {r.mode} {r.step:g}: {r.failed}" for r in rows if not r.passed]
    assert not bad, "\n".join(bad)


def test_chain_error_is_the_explicit_cut(fmu_path, tmp_path):
    """large_step_chain at 1e-2 s on load_100x: the FMU's TE is far (> 0.5 um) from the converged
    chain but within 0.05 um of the same chain and cut with the gear pair converged
    (cut_reference_te, the plain element under the implicit master between the communication
    points): the difference is the explicit cut's, not the FMU's. The cut reference itself tends
    to the converged chain as the communication step shrinks (1e-2 s -> 1e-3 s: its distance
    falls by at least 5x, first order)."""
    prep = prepare(select(["load_100x"])[0], fmu_path, tmp_path)
    run = stability.run_suite(fmu_path, [prep.case], ["large_step_chain"], [1e-2],
                              progress=False)[0]
    assert run.passed, run.failed
    cut_off = run.cut_te_error * 1e6
    assert cut_off > 0.5
    t_fine = np.arange(1, int(round(prep.case.t_end / 1e-3)) + 1) * 1e-3
    fine = cut_reference_te(prep, t_fine)
    converged = converged_te(prep, "chain", t_fine)
    keep = t_fine >= SETTLE
    fine_off = max(abs(fine[keep].mean() - converged[keep].mean()),
                   abs(np.ptp(fine[keep]) - np.ptp(converged[keep]))) * 1e6
    assert fine_off < cut_off / 5, (fine_off, cut_off)


def test_small_step_exceptions_are_te_cases():
    """SMALL_STEP_OPEN names cases whose TE is judged (against the converged dynamics)."""
    te_cases = {c.name for c in select(None) if c.te_check}
    assert len(te_cases) >= 20 and set(stability.SMALL_STEP_OPEN) <= te_cases


def test_converged_chain_starts_in_equilibrium(fmu_path, tmp_path):
    """The implicit master's copy of large_step_chain (the converged chain reference) starts
    where the chain starts: machine, shafts, gears and load inertia at rest relative to each
    other, every acceleration ~0 (a wrong load sign or controller state would accelerate)."""
    prep = prepare(select(["nominal"])[0], fmu_path, tmp_path)
    with GearMeshFMU(prep.fmu_path, prep.params) as fmu:
        fmu.set(prep.inputs)
        plant = chain_plant(prep, fmu)
        x = plant.x0
        fmu.step({"gear1.phi": x[3], "gear1.omega": x[4], "gear2.phi": x[5],
                  "gear2.omega": x[6]}, 1e-6)
        m = fmu.get(["gear1.mz", "gear2.mz"])
    dx = plant.rhs(0.0, x, np.array([m["gear1.mz"], m["gear2.mz"]]))
    torques = dx[[1, 4, 6, 8]] * np.array([plant.p.J_motor, plant.p.J1, plant.p.J2,
                                           plant.p.J_load])
    assert abs(m["gear2.mz"]) > 100.0
    assert np.max(np.abs(torques)) < 1e-3 * abs(m["gear2.mz"]), torques
    assert abs(dx[2]) < 1e-12  # machine at its set speed


def test_converged_reference_is_sampled_at_the_run_times(fmu_path, tmp_path):
    prep = prepare(select(["nominal"])[0], fmu_path, tmp_path)
    prep.converged["pair"] = (np.array([0.1, 0.2, 0.3]), np.array([1.0, 3.0, 2.0]))
    assert np.allclose(converged_te(prep, "pair", np.array([0.2, 0.25, 0.3])), [3.0, 2.5, 2.0])


def _run(**kw) -> Run:
    t = np.linspace(0.02, 0.1, 50)
    base = dict(case="nominal", mode="explicit", step=1e-3, t=t, te=np.full(50, 5e-6),
                phi1=t, force=np.full(50, 1e3), flank=np.ones(50), residual=0.0, work_in=10.0,
                steps=50, te_ref=np.full(50, 5e-6))
    base.update(kw)
    return Run(**base)


@pytest.mark.parametrize("change, why", [
    (dict(error="fmi2DoStep failed"), "error"),
    (dict(nan_count=1), "non-finite"),
    (dict(unconverged=1), "unconverged"),
    (dict(residual=0.2), "energy residual"),
    (dict(te=np.full(50, 5.06e-6)), "TE"),
    (dict(te=5e-6 + 0.06e-6 * np.sin(np.linspace(0, 6, 50))), "TE"),
])
def test_each_judgement_can_fail(change, why):
    case = select(["nominal"])[0]
    ok, stable, _ = stability.judge(case, _run())
    assert ok and stable
    ok, _, text = stability.judge(case, _run(**change))
    assert not ok and why in text


def test_case_checks_can_fail():
    rattle, free, roll = select(["rattle", "free_in_backlash", "rollback"])
    assert not stability.judge(rattle, _run(case="rattle"))[0]           # flank 2 never hit
    assert stability.judge(rattle, _run(flank=np.r_[np.ones(25), 2 * np.ones(25)]))[0]
    assert not stability.judge(free, _run(case="free_in_backlash"))[0]   # it touched
    assert not stability.judge(roll, _run(rollback_gap=1e-9))[0]
    assert stability.judge(roll, _run(rollback_gap=0.0))[0]


def test_undamped_checks_can_fail():
    """An undamped case is judged by the energy the run made against its largest energy (not
    the work in, which balanced torques make large) and by the growth of its peak force."""
    undamped = select(["undamped_10rpm"])[0]
    calm = dict(case="undamped_10rpm", mode="large_step", work_in=600.0, largest_energy=0.05)
    assert stability.judge(undamped, _run(residual=+0.01, **calm))[0]             # lost: allowed
    ok, _, text = stability.judge(undamped, _run(residual=-0.006, **calm))        # 1 % of the work in
    assert not ok and "energy made" in text
    ok, _, text = stability.judge(undamped, _run(force=np.r_[np.full(25, 1e3), np.full(25, 2e3)], **calm))
    assert not ok and "grew" in text


def test_largest_stable_step():
    mk = lambda h, ok: stability.Row("c", "m", h, ok, ok, None, 0, 0, 0, 0, 0, 0, 0, 0, "")
    rows = [mk(1e-5, True), mk(1e-4, True), mk(1e-3, False), mk(1e-2, True)]
    assert stability.largest_stable(rows)[("c", "m")] == 1e-4
    assert stability.largest_stable([mk(1e-5, False)])[("c", "m")] == 0.0


def test_bad_options_are_named():
    with pytest.raises(ValueError, match="--modes: unknown mode"):
        stability.parse_modes(["bogus"])
    with pytest.raises(ValueError, match=r"allowed range \[1e-07, 0.1\]"):
        stability.parse_steps(["1"], False)
    with pytest.raises(ValueError, match="--cases: unknown case"):
        select(["no_such_case"])
    assert math.isclose(stability.parse_steps(["1e-3,1e-4"], False)[0], 1e-4)
