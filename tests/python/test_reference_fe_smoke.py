"""Smoke test of the CalculiX reference (reference_fe): set A, plane strain, one position at a
coarse mesh, two torques in one ccx run (about 30 s of CPU).

Position 0 puts tooth pair 0 at the pitch point; with eps_alpha = 1.67 no other pair is on the
path there (pairs +-1 sit one base pitch away, beyond the 0.84 p_b of approach and recess), so
one tooth pair carries the load. Checks, each able to fail:

* TE > 0 at both torques (the contact carried the torque on flank A: a sign error in the
  placement, the torque or the TE would give a negative or zero TE);
* the TE at 150 N m lies within x0.5 .. x2 of the single-pair estimate F_bt / (b c') of
  ISO 6336-1:2019 method B (c' from q'_min of eq. (70) with C_M = 0.8, C_R = 1 (solid disc),
  C_B from the rack, E/E_st = 1, and the load correction (F_t / b / 100 N/mm)^0.25 below
  100 N/mm): an independent, empirical single-pair stiffness, not this model. A missing face
  width (thickness 1 mm) would be 23x off, a wrong modulus or a free body far off as well;
* TE ~ T^n between 50 and 150 N m with 0.85 <= n <= 1.02: bending and body deflection are
  linear in the load and the 2-D Hertz approach grows slightly less than linearly
  (w ~ F (ln(c/F) + const)), so the pair stiffens a little; a contact that had not closed
  (TE set by the initial closure) or a penalty that dominated would break this;
* the per-tooth contact totals (*CONTACT PRINT CF, reference_fe/pairs.py): their moments about
  gear 1's axis add up to the torque (equilibrium; a misread block or unit would not), tooth 0
  carries it all (single contact) and its force is the torque over the base radius
  (frictionless: the force lies on the line of action, at r_b1 from the axis).
"""
from __future__ import annotations

import math
import tempfile

import pytest


from reference_fe import analysis, mesh, scene  # noqa: E402
from conftest import REPO



pytestmark = pytest.mark.usefixtures("ccx_installed")


def iso_single_pair_stiffness(spec: scene.PairSpec, torque: float, rb1: float) -> float:
    """c' (N/m^2) of ISO 6336-1 method B for a spur pair with a solid blank."""
    z1, z2 = spec.gear1.teeth, spec.gear2.teeth
    x1, x2 = spec.gear1.shift, spec.gear2.shift
    q = (0.04723 + 0.15551 / z1 + 0.25791 / z2 - 0.00635 * x1 - 0.11654 * x1 / z1
         - 0.00193 * x2 - 0.24188 * x2 / z2 + 0.00529 * x1 ** 2 + 0.00182 * x2 ** 2)
    c_th = 1.0 / q                                          # N/(mm um)
    c_b = ((1 + 0.5 * (1.2 - spec.rack_dedendum))
           * (1 - 0.02 * (20.0 - math.degrees(spec.pressure_angle))))
    c = c_th * 0.8 * 1.0 * c_b
    ft_per_b = (2 * torque / (spec.module * z1)) / spec.gear1.face_width / 1e3   # N/mm
    if ft_per_b < 100.0:
        c *= (ft_per_b / 100.0) ** 0.25
    return c * 1e9                                          # N/(mm um) -> N/m^2


def test_single_pair_te_at_the_pitch_point():
    spec = scene.load(REPO / "scenarios" / "paper_setA_3U4U.toml")
    m = spec.module
    coarse = mesh.MeshSize(h_contact=0.05 * m, h_tooth=0.3 * m, h_far=1.2 * m, h_body=4 * m,
                           grad=0.5)
    model = analysis.Model(spec, level=0, size=coarse)
    torques = [50.0, 150.0]
    case = analysis.Case(model="plane_strain")
    with tempfile.TemporaryDirectory() as wd:
        r = model.solve_position(case, 0, 20, torques, wd)
    te50, te150 = r.te
    print(f"TE {te50 * 1e6:.3f} / {te150 * 1e6:.3f} um at 50 / 150 N m, {r.wall_s:.1f} s, "
          f"{r.max_rss_MiB:.0f} MiB")
    assert te50 > 0 and te150 > 0
    rb1 = model.pair.g1.rb
    c = iso_single_pair_stiffness(spec, 150.0, rb1)
    te_iso = (150.0 / rb1) / (spec.gear1.face_width * c)
    print(f"ISO 6336-1 single pair F/(b c'): {te_iso * 1e6:.3f} um, ratio {te150 / te_iso:.3f}")
    assert 0.5 < te150 / te_iso < 2.0, (te150, te_iso)
    n = math.log(te150 / te50) / math.log(3.0)
    print(f"exponent n = {n:.4f}")
    assert 0.85 <= n <= 1.02, n
    for T, forces, moments in zip(torques, r.pair_force_N, r.pair_moment_Nm):
        assert abs(sum(moments.values())) == pytest.approx(T, rel=1e-4)
        assert forces["0"] == pytest.approx(T / rb1, rel=1e-3)
        assert sum(f for tooth, f in forces.items() if tooth != "0") < 1e-6 * forces["0"]
