"""First contact physics through the FMU, driven by fmpy with prescribed spin angles
(issue 2): backlash, k b Delta on flank A, flank B at TE = -j_bt, force and moment balance.

The backlash is recomputed here from the ISO 21771 formulas, independently of the core. The pairs
are at level 0 on one slice (LEVEL0, set explicitly: the defaults are level 4 with 10 slices),
whose forces have the closed form k' b Delta."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gearmesh.fmu_driver import GearMeshFMU, FMUError
from gearmesh.prescribed_motion import pair_kinematics

from test_fmu_conformance import LEVEL0

K_PRIME = 1.5e10  # N/m^2, the default user stiffness per unit face width
FACE = 0.023


def inv(a: float) -> float:
    return math.tan(a) - a


def iso_backlash_spur(z1, z2, m, alpha, x1, x2, a, internal=False):
    """j_bt along the line of action, ISO 21771 with the signed convention for the ring."""
    if internal:
        z2 = -z2
        a = -a
    d1, d2 = z1 * m, z2 * m
    a_d = (d1 + d2) / 2
    alpha_w = math.acos(a_d * math.cos(alpha) / a)
    dw1, dw2 = d1 * math.cos(alpha) / math.cos(alpha_w), d2 * math.cos(alpha) / math.cos(alpha_w)

    def s_w(d, dw, x):
        s = m * (math.pi / 2 + 2 * x * math.tan(alpha))
        return dw * (s / d + inv(alpha) - inv(alpha_w))

    j_wt = math.pi * dw1 / z1 - s_w(d1, dw1, x1) - s_w(d2, dw2, x2)
    return j_wt * math.cos(alpha_w)


RING = {"pair.internal": True, "pair.normal_module": 0.002, "gear1.teeth": 21,
        "gear2.teeth": 62, "gear1.profile_shift": 0.1, "gear2.profile_shift": -0.2,
        "pair.center_distance": 0.041}


@pytest.fixture(params=["external", "internal"])
def pair(request, fmu_path):
    params = {**LEVEL0, **({} if request.param == "external" else RING)}
    with GearMeshFMU(fmu_path, params, instance_name=request.param) as fmu:
        yield request.param, params, fmu


def pose(fmu, te, phi1=0.0):
    kin = pair_kinematics(fmu)
    return {"gear1.phi": phi1, "gear2.phi": kin.phi2(te, phi1)}


def evaluate(fmu, te, phi1=0.0, names=("mesh.normal_force", "mesh.flank",
                                       "mesh.pairs_in_contact", "mesh.stiffness")):
    fmu.step(pose(fmu, te, phi1))
    return fmu.get(list(names))


def test_backlash_matches_iso_21771(pair):
    kind, params, fmu = pair
    p = {"z1": 57, "z2": 57, "m": 0.0026, "x1": 0.35, "x2": 0.35, "a": 0.150}
    if kind == "internal":
        p = {"z1": 21, "z2": 62, "m": 0.002, "x1": 0.1, "x2": -0.2, "a": 0.041}
    expected = iso_backlash_spur(p["z1"], p["z2"], p["m"], math.radians(20), p["x1"], p["x2"],
                                 p["a"], internal=kind == "internal")
    assert expected > 0
    assert fmu.get(["geometry.backlash"])["geometry.backlash"] == pytest.approx(expected, rel=1e-9)


def test_zero_force_inside_the_backlash(pair):
    _, _, fmu = pair
    j = fmu.get(["geometry.backlash"])["geometry.backlash"]
    for phi1 in np.linspace(0, 0.2, 7):
        for frac in (0.001, 0.3, 0.999):
            out = evaluate(fmu, -frac * j, phi1)
            assert out["mesh.normal_force"] == 0.0
            assert out["mesh.flank"] == 0


def _poses_by_pairs(fmu, te):
    """Gear-1 angles over one base pitch grouped by the number of loaded pairs."""
    pb = fmu.get(["geometry.base_pitch"])["geometry.base_pitch"]
    rb1 = pair_kinematics(fmu).r_b1
    groups: dict[int, list[float]] = {}
    for phi1 in np.linspace(0, pb / rb1, 200, endpoint=False):
        groups.setdefault(int(evaluate(fmu, te, phi1)["mesh.pairs_in_contact"]), []).append(phi1)
    return groups


def test_flank_a_force_is_k_b_delta(pair):
    _, _, fmu = pair
    delta = 1e-6
    groups = _poses_by_pairs(fmu, delta)
    assert set(groups) == {1, 2}
    for pairs, angles in groups.items():
        mid = angles[len(angles) // 2]
        out = evaluate(fmu, delta, mid)
        assert out["mesh.flank"] == 1
        assert out["mesh.normal_force"] == pytest.approx(pairs * K_PRIME * FACE * delta, rel=1e-9)
        assert out["mesh.stiffness"] == pytest.approx(pairs * K_PRIME * FACE, rel=1e-9)


def test_flank_b_engages_at_minus_backlash(pair):
    _, _, fmu = pair
    j = fmu.get(["geometry.backlash"])["geometry.backlash"]
    phi1 = 0.05
    just_open = evaluate(fmu, -j * (1 - 1e-6), phi1)
    assert just_open["mesh.normal_force"] == 0.0
    pressed = evaluate(fmu, -j - 5e-6, phi1)
    assert pressed["mesh.flank"] == 2
    n = pressed["mesh.pairs_in_contact"]
    assert pressed["mesh.normal_force"] == pytest.approx(n * K_PRIME * FACE * 5e-6, rel=1e-6)


def test_force_and_moment_balance(pair):
    kind, _, fmu = pair
    names = [f"gear{i}.{q}" for i in (1, 2) for q in ("fx", "fy", "fz", "mx", "my", "mz")]
    kin = pair_kinematics(fmu)
    alpha_w = fmu.get(["geometry.operating_pressure_angle"])["geometry.operating_pressure_angle"]
    j = fmu.get(["geometry.backlash"])["geometry.backlash"]
    for te, flank in ((1e-6, 1), (-j - 1e-6, -1)):
        # mid-zone pose of single contact at a small approach: the tip edges of the pairs
        # outside the path stay clear (their contact zone grows like sqrt(approach))
        singles = _poses_by_pairs(fmu, te)[1]
        fmu.step(pose(fmu, te, singles[len(singles) // 2]))
        out = fmu.get(names + ["mesh.normal_force"])
        F = out["mesh.normal_force"]
        assert F > 0
        for q in ("fx", "fy", "fz"):
            assert out[f"gear1.{q}"] == pytest.approx(-out[f"gear2.{q}"], abs=1e-9 * F)
        # along the line of action: |f| = F, |fy| = F cos(alpha_w)
        assert math.hypot(out["gear2.fx"], out["gear2.fy"]) == pytest.approx(F, rel=1e-12)
        assert abs(out["gear2.fy"]) == pytest.approx(F * math.cos(alpha_w), rel=1e-12)
        # moments = force x base radius; the ring turns with the pinion
        assert out["gear1.mz"] == pytest.approx(-flank * F * kin.r_b1, rel=1e-12)
        assert out["gear2.mz"] == pytest.approx(-flank * kin.sign * F * kin.r_b2, rel=1e-12)


def test_reversal_and_reengagement_over_a_rattle_cycle(fmu_path):
    """TE swept A -> through the backlash -> B -> back: force follows the same line both ways."""
    with GearMeshFMU(fmu_path) as fmu:
        j = fmu.get(["geometry.backlash"])["geometry.backlash"]
        tes = np.concatenate([np.linspace(5e-6, -j - 5e-6, 60), np.linspace(-j - 5e-6, 5e-6, 60)])
        outs = [evaluate(fmu, te, 0.0) for te in tes]
    forces = np.array([o["mesh.normal_force"] for o in outs])
    flanks = [o["mesh.flank"] for o in outs]
    assert np.allclose(forces[:60], forces[60:][::-1], rtol=1e-12, atol=0)
    assert flanks[0] == 1 and flanks[59] == 2 and flanks[-1] == 1


def test_centre_distance_input_opens_the_mesh(fmu_path):
    """Moving gear 2 away by da opens both flanks equally (symmetric teeth): flank A loses half
    the backlash change, with the backlash at a + da from a second instance's geometry."""
    da = 5e-6
    with GearMeshFMU(fmu_path, {"pair.center_distance": 0.150 + da}) as wider:
        j_wide = wider.get(["geometry.backlash"])["geometry.backlash"]
    with GearMeshFMU(fmu_path, LEVEL0) as fmu:
        j = fmu.get(["geometry.backlash"])["geometry.backlash"]
        te = 3e-6
        singles = _poses_by_pairs(fmu, te)[1]
        phi1 = singles[len(singles) // 2]
        base = evaluate(fmu, te, phi1)["mesh.normal_force"]
        fmu.step({**pose(fmu, te, phi1), "gear2.ux": da})
        moved = fmu.get(["mesh.normal_force", "mesh.pairs_in_contact"])
        k = moved["mesh.pairs_in_contact"] * K_PRIME * FACE
        assert base - moved["mesh.normal_force"] == pytest.approx(k * (j_wide - j) / 2, rel=1e-9)


def test_non_physical_penetration_is_a_clear_error(fmu_path):
    with GearMeshFMU(fmu_path) as fmu:
        pb = fmu.get(["geometry.base_pitch"])["geometry.base_pitch"]
        with pytest.raises(FMUError, match="detection range"):
            fmu.step(pose(fmu, 0.3 * pb))


def test_design_warnings_reach_the_user(fmu_path):
    """An unshifted 12-tooth pinion is undercut (z < 17 for a 20 deg rack): initialization
    returns fmi2Warning and the message names the gear; the default pair has no warning. At
    level 0 (LEVEL0): the default level 4's analytical tooth compliance refuses an undercut tooth
    (an Error naming gear1.profile_shift), so only level 0 shows the warning alone."""
    with GearMeshFMU(fmu_path) as fmu:
        assert fmu.warnings == []
    undercut = {"gear1.teeth": 12, "gear1.profile_shift": 0.0, "gear2.profile_shift": 0.0,
                "pair.center_distance": 0.0026 * (12 + 57) / 2 + 40e-6}
    with pytest.raises(FMUError, match="gear1.profile_shift: analytical tooth compliance needs a "
                                       "tooth without undercut"):
        GearMeshFMU(fmu_path, undercut)
    with GearMeshFMU(fmu_path, {**LEVEL0, **undercut}) as fmu:
        assert any("gear1" in w and "undercut" in w for w in fmu.warnings), fmu.warnings
        fmu.step(pose(fmu, 5e-6))  # still usable
        assert fmu.get(["mesh.normal_force"])["mesh.normal_force"] > 0
