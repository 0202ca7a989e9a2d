"""The reference drivetrain through fmpy (issue 5): it reproduces the quasi-static TE at 10 rpm,
its energy balance closes, and the implicit scheme is stable where explicit coupling is not."""
from __future__ import annotations

import numpy as np
import pytest

from gearmesh.drivetrain import Drivetrain, simulate
from gearmesh.fmu_driver import FMUError, GearMeshFMU

PARAMS = {"model.stiffness": 4, "model.slices": 5}


@pytest.fixture(scope="module")
def steady(fmu_path):
    p = Drivetrain(spin_up=0.1)
    with GearMeshFMU(fmu_path, PARAMS) as fmu:
        return p, simulate(fmu, p, 1.2, 1e-3)


def test_drivetrain_at_10_rpm_reproduces_the_quasi_static_te(steady, fmu_path):
    """After spin-up, the dynamic TE over the last 0.2 s (two mesh periods) equals the
    quasi-static TE at the brake torque within 0.1 um: at 9.5 Hz mesh frequency the gear
    inertias barely matter."""
    p, r = steady
    late = r.t[1:] > 1.0
    phi1, te = r.x[1:, 3][late], r.mesh["mesh.te"][late]
    assert np.mean(r.x[1:, 4][late]) == pytest.approx(10 * 2 * np.pi / 60, rel=0.01)
    with GearMeshFMU(fmu_path, {**PARAMS, "model.quasi_static": True}) as qs:
        te_qs = []
        for a in phi1:
            qs.step({"gear1.phi": a, "mesh.load_torque": p.brake_torque})
            te_qs.append(qs.get(["mesh.te"])["mesh.te"])
    assert np.max(np.abs(te - np.array(te_qs))) < 0.1e-6


def test_energy_balance_closes(steady):
    """Motor work + brake work = stored + damper losses + what the mesh absorbs (its
    elastic energy change and friction), to 0.1 % of the motor work."""
    _, r = steady
    e = r.energy
    assert e["motor"] > 0 and e["brake"] < 0
    assert abs(e["residual"]) < 1e-3 * e["motor"]


def test_implicit_is_stable_where_explicit_coupling_fails(fmu_path):
    p = Drivetrain(spin_up=0.1)
    with GearMeshFMU(fmu_path, PARAMS) as fmu:
        implicit = simulate(fmu, p, 0.05, 1e-3)
    assert np.all(np.isfinite(implicit.x))
    with GearMeshFMU(fmu_path, PARAMS) as fmu:
        # beyond 2/omega_mesh it blows up: a step skips teeth, which the FMU discards
        with pytest.raises(FMUError, match="mesh.te would jump by") as failed:
            simulate(fmu, p, 0.05, 1e-3, implicit=False)
        assert failed.value.discarded
    with GearMeshFMU(fmu_path, PARAMS) as fmu:
        explicit = simulate(fmu, p, 0.05, 2e-5, implicit=False)  # below the limit: agrees
    assert explicit.x[-1, 4] == pytest.approx(implicit.x[-1, 4], rel=0.01)
    assert explicit.mesh["mesh.te"][-1] == pytest.approx(implicit.mesh["mesh.te"][-1], abs=0.1e-6)


def test_bearing_stiffness_on_the_gear_centres(fmu_path):
    """With bearings, the gear centres move under the mesh force: at steady state each centre
    sits at f/k_b (static deflection), the mesh sees that displacement through gear<i>.ux/uy,
    and the energy balance (bearing springs and dampers included) still closes."""
    p = Drivetrain(spin_up=0.1, bearing_stiffness=5e8, bearing_damping=2e4)
    with GearMeshFMU(fmu_path, PARAMS) as fmu:
        r = simulate(fmu, p, 1.2, 1e-3)
    late = r.t[1:] > 1.0
    for gear, col in ((1, 9), (2, 13)):
        for axis, off in (("x", 0), ("y", 1)):
            u = r.x[1:, col + off][late].mean()
            f = r.mesh[f"gear{gear}.f{axis}"][late].mean()
            assert abs(u) > 1e-7  # it moved
            assert u == pytest.approx(f / p.bearing_stiffness, rel=1e-3)
    assert abs(r.energy["residual"]) < 1e-3 * r.energy["motor"]
