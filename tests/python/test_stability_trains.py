"""The train cases of the stability suite (`gearmesh stability --trains`, gearmesh.stability.trains,
docs/stability.md "Gear trains"): the undamped 3-planet stage at 1e-2 s and the damped two-stage
reducer at 1e-3 s pass every judgement under the explicit master; the judge fails made-up runs
that made energy, ran away or whose mesh oscillation grew, so that a judgement that could not
fail would show here; the undamped copies of a scene have no mesh or inner-shaft damping and keep
the port shaft's."""
from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from conftest import REPO
from gearmesh.stability import trains as st
from gearmesh.stability.suite import ENERGY_TOL, UNDAMPED_GAIN


def one_row(fmu_path, case: st.TrainCase, step: float) -> st.TrainRow:
    rows = st.run_suite(fmu_path, [case], [step], progress=False)
    assert len(rows) == 1
    return rows[0]


def test_undamped_planetary_passes_at_1e_2(fmu_path, tmp_path):
    r = one_row(fmu_path, st.TrainCase("planetary_3_planets", damped=False), 1e-2)
    assert r.passed, r.failed
    assert r.simulated == pytest.approx(st.DURATION)
    assert r.steady is True                                  # so the envelope was judged
    assert r.mesh and 0 < r.envelope_last <= r.envelope_first + r.ripple
    assert 0 <= r.max_speed <= 1 and r.energy <= UNDAMPED_GAIN  # this run is well inside the first term alone
    st.write_outputs([r], tmp_path, 1.0)
    assert "| planetary_3_planets | undamped | 0.01 | pass |" in (tmp_path / "results.md").read_text()
    assert (tmp_path / "results.json").is_file()


def test_damped_reducer_passes_at_1e_3(fmu_path):
    r = one_row(fmu_path, st.TrainCase("two_stage_reducer", damped=True), 1e-3)
    assert r.passed, r.failed
    assert r.simulated == pytest.approx(st.DURATION)
    assert abs(r.residual) <= ENERGY_TOL * r.scale and r.scale > 0
    assert r.steady is None                                  # the envelope is the undamped runs'


def synthetic(residual: float, largest: float = 10.0, grow: float = 1.0,
              speed: float = 100.0) -> st.TrainRun:
    """A made-up run of one body and one mesh at 1e-2 s: steady at 100 rad/s (`speed` at the
    last sample), kinetic + elastic energy up to `largest`, the residual ramping to `residual`,
    a 1 um TE ripple whose envelope is `grow` times wider in the last window."""
    t = np.arange(0, st.DURATION + 1e-9, 1e-2)
    n = len(t)
    w = np.full(n, 100.0)
    w[-1] = speed
    scale = np.where(t > t[-1] - st.TE_WINDOW, grow, 1.0)
    te = 1e-6 * np.sin(2 * math.pi * 0.37 * np.arange(n)) * scale
    energy = {k: np.zeros(n) for k in st.ENERGY}
    energy["energy.kinetic"][:] = largest
    energy["energy.work_in"][:] = np.linspace(0, 100 * largest, n)
    energy["energy.residual"][:] = np.linspace(0, residual, n)
    return st.TrainRun("synthetic", 1e-2, t=t, speeds=w[None, :], motor=w.copy(), te={"mesh": te},
                       energy=energy, steps=n - 1, w_ref=100.0, port_column=0, speed_bound=300.0)


RIPPLE = {"mesh": 0.5e-6}


def test_judge_passes_a_clean_run():
    v = st.judge(synthetic(residual=+0.01), damped=False, ripple=RIPPLE)
    assert v.passed and v.steady, v.failed


def test_judge_fails_energy_made():
    """Undamped: twice the allowance made (UNDAMPED_GAIN of the largest energy, 10 J, plus
    THROUGHPUT_DRIFT of the 1000 J passed through) fails, just under it passes; damped: a
    residual beyond ENERGY_TOL of the work in, either sign, fails."""
    allowance = UNDAMPED_GAIN * 10.0 + st.THROUGHPUT_DRIFT * 1000.0
    v = st.judge(synthetic(residual=-2 * allowance), damped=False, ripple=RIPPLE)
    assert not v.passed and any("energy made" in f for f in v.failed)
    assert v.energy == pytest.approx(2 * allowance / 10.0)
    assert st.judge(synthetic(residual=-0.99 * allowance), damped=False, ripple=RIPPLE).passed
    damped = synthetic(residual=-2 * ENERGY_TOL * 1000.0)   # work in 1000 J
    v = st.judge(damped, damped=True)
    assert not v.passed and any("of the work in" in f for f in v.failed)


def test_judge_fails_growth_and_runaway():
    v = st.judge(synthetic(residual=0.0, grow=1.5), damped=False, ripple=RIPPLE)  # 2 um -> 3 um
    assert not v.passed and any("envelope grew" in f for f in v.failed)
    assert st.judge(synthetic(residual=0.0, grow=1.2), damped=False, ripple=RIPPLE).passed
    v = st.judge(synthetic(residual=0.0, speed=400.0), damped=False, ripple=RIPPLE)
    assert not v.passed and any("beyond the bound" in f for f in v.failed)
    v = st.judge(synthetic(residual=0.0, speed=math.nan), damped=False, ripple=RIPPLE)
    assert not v.passed


def test_undamped_copy_drops_mesh_and_inner_shaft_damping(tmp_path):
    train = st.undamped_copy(REPO / "scenarios" / "trains" / "back_to_back_set_a.toml", tmp_path)
    data = tomllib.loads(train.read_text())
    damping = {s["name"]: s["damping_Nms_per_rad"] for s in data["shaft"]}
    assert damping == {"motor": 10.0, "pinion_shaft": 0.0, "wheel_shaft": 0.0}
    for mesh in data["mesh"]:
        pair = tomllib.loads((tmp_path / mesh["scene"]).read_text())
        assert pair["model"]["damping_Ns_per_m2"] == 0.0
        assert pair["model"]["friction_coefficient"] == 0.4      # friction stays
    reducer = st.undamped_copy(REPO / "scenarios" / "trains" / "two_stage_reducer.toml", tmp_path / "r")
    reducer = tomllib.loads(reducer.read_text())
    assert [m["scene"] for m in reducer["mesh"]] == ["stage1_19_57.toml", "stage2_23_61.toml"]
