"""Geometry of reference_fe's 3-D meshes (mesh3d, model3d), without running CalculiX.

* helical_fe (31/47, beta 15 deg): every node of gear 1's and gear 2's contact faces (flank A
  involute and tip of the fine teeth, mid-side nodes included) lies on the involute helicoid
  of ISO 21771 within 0.05 um along the transverse arc at the node's radius: the polar angle
  theta = k tau + psi(R) + hand z tan(beta_b) / r_b, psi the closed-form involute half angle
  (Gear.involute_psi), beta_b from sin beta_b = sin beta cos alpha_n (an independent route to
  the twist rate the mesh uses, tan(beta) / r); a wrong hand, lead or a section not twisted
  would be off by microns to millimetres;
* the face width (z from -b/2 to b/2), the sector's teeth (fine teeth +- margin) and the held
  nodes (on the bore circle or on the two radial cut lines at the sector's mid-spaces);
* paper_setA_lead_crowned: the contact flank of gear 1 is the involute moved along its normal
  by C_beta (2 z / b)^2 within 0.05 um (measured as r_b times the polar-angle offset from the
  unmodified involute), and 0 at mid-face.
"""
from __future__ import annotations

import math

import numpy as np
import pytest


from reference_fe import geometry, mesh3d, model3d, scene  # noqa: E402
from conftest import REPO

# faces of a hex20 / wedge15 side S3..S6 / S3..S5: the section edge j (corner nodes and mid)
_SIDE = {20: {3: [0, 1, 5, 4, 8, 12, 16, 17], 4: [1, 2, 6, 5, 9, 13, 17, 18],
              5: [2, 3, 7, 6, 10, 14, 18, 19], 6: [3, 0, 4, 7, 11, 15, 19, 16]},
         15: {3: [0, 1, 4, 3, 6, 9, 12, 13], 4: [1, 2, 5, 4, 7, 10, 13, 14],
              5: [2, 0, 3, 5, 8, 11, 14, 12]}}


def coarse(spec, sector_deg=40.0):
    m = spec.module
    size = mesh3d.Size3D(h_contact=0.3 * m, h_tooth=0.6 * m, h_far=1.5 * m, h_body=4 * m,
                         grad=0.6, layers=4, sector=math.radians(sector_deg))
    return model3d.Model3D(spec, 0, size=size)


def contact_nodes(sm: mesh3d.SolidMesh) -> np.ndarray:
    """Node indices of the contact faces (all 8 nodes of each face)."""
    elems = [c for _, c in sm.blocks]
    offs = np.cumsum([0] + [len(c) for c in elems])
    out = set()
    for e, j in sm.contact_faces:
        b = int(np.searchsorted(offs, e, side="right") - 1)
        conn = elems[b][e - offs[b]]
        out.update(int(n) for n in conn[_SIDE[conn.shape[0]][j]])
    return np.array(sorted(out))


def flank_A_nodes(g: geometry.Gear, sm: mesh3d.SolidMesh, nodes):
    """Contact-face nodes on flank A's involute (not on the tip arc): (R, theta, z)."""
    x, y, z = sm.nodes[nodes].T
    R = np.hypot(x, y)
    keep = R < g.ra - 1e-7
    return R[keep], np.arctan2(y, x)[keep], z[keep]


@pytest.mark.parametrize("i,hand", [(1, +1), (2, -1)])
def test_helical_flank_nodes_on_the_involute_helicoid(i, hand):
    spec = scene.load(REPO / "scenarios" / "fe" / "helical_fe.toml", dims=3)
    model = coarse(spec)
    g = model.pair.g1 if i == 1 else model.pair.g2
    sm = model.m1 if i == 1 else model.m2
    R, theta, z = flank_A_nodes(g, sm, contact_nodes(sm))
    assert len(R) > 100
    beta_b = math.asin(math.sin(spec.helix_angle) * math.cos(spec.pressure_angle))
    ideal = g.involute_psi(R) + hand * z * math.tan(beta_b) / g.rb
    k = np.round((theta - ideal) / g.tau)
    dev = R * (theta - k * g.tau - ideal)         # along the transverse arc, m
    print(f"gear{i}: {len(R)} flank nodes, worst {np.abs(dev).max() * 1e6:.4f} um")
    assert np.abs(dev).max() < 0.05e-6
    # the teeth of the contact faces are the fine teeth
    assert sorted({int(v) % g.z for v in k}) == sorted(t % g.z for t in sm.contact_teeth)


def test_face_width_sector_teeth_and_held_nodes():
    spec = scene.load(REPO / "scenarios" / "paper_setA_3U4U.toml", dims=3)
    model = coarse(spec, sector_deg=200.0)     # more than half the gear: two bore arcs
    for g, sm in ((model.pair.g1, model.m1), (model.pair.g2, model.m2)):
        z = sm.nodes[:, 2]
        assert z.min() == pytest.approx(-g.b / 2, abs=1e-12)
        assert z.max() == pytest.approx(g.b / 2, abs=1e-12)
        fine = sm.contact_teeth
        margin = round((math.radians(200.0) / g.tau - len(fine)) / 2)
        assert sm.sector_teeth == list(range(fine[0] - margin, fine[-1] + margin + 1))
        assert abs(len(sm.sector_teeth) * g.tau - math.radians(200.0)) <= g.tau
        # every node inside the sector's angle, held nodes on the bore or the cut lines
        x, y = sm.nodes[:, 0], sm.nodes[:, 1]
        a0 = (sm.sector_teeth[0] - 0.5) * g.tau
        a1 = (sm.sector_teeth[-1] + 0.5) * g.tau
        ang = np.arctan2(y, x)
        ang = np.where(ang < a0 - 1e-9, ang + 2 * math.pi, ang)   # the sector crosses +-pi
        assert ang.min() > a0 - 1e-9 and ang.max() < a1 + 1e-9
        hx, hy = x[sm.bore], y[sm.bore]
        on_bore = np.abs(np.hypot(hx, hy) - g.bore) < 1e-9
        ha = np.arctan2(hy, hx)
        on_cut = np.zeros(len(ha), bool)
        for a in (a0, a1):
            on_cut |= np.abs(np.angle(np.exp(1j * (ha - a)))) < 1e-9
        assert np.all(on_bore | on_cut)
        assert on_bore.sum() > 0 and on_cut.sum() > 0


def test_lead_crowning_on_the_flank():
    spec = scene.load(REPO / "scenarios" / "paper_setA_lead_crowned.toml", dims=3)
    cb = spec.gear1.mod.lead_crowning
    assert cb == pytest.approx(5e-6)
    model = coarse(spec)
    g, sm = model.pair.g1, model.m1
    R, theta, z = flank_A_nodes(g, sm, contact_nodes(sm))
    ideal = g.involute_psi(R)
    k = np.round((theta - ideal) / g.tau)
    removed = g.rb * (ideal - (theta - k * g.tau))     # material removed along the normal
    expect = cb * (2 * z / g.b) ** 2
    print(f"worst {np.abs(removed - expect).max() * 1e6:.4f} um, ends "
          f"{removed[np.abs(z) > g.b / 2 - 1e-9].mean() * 1e6:.3f} um")
    assert np.abs(removed - expect).max() < 0.05e-6
    assert removed[np.abs(z) < 1e-9].max() < 0.05e-6


def test_whole_lightweight_gear_web_hub_and_holes():
    """lightweight_vs_solid_fe's gear 1 as a whole gear (sector 360 deg): every node within the
    face width, the rim and hub over it, the web only between its faces (|z - offset| <= t/2
    for every node between the hub and the rim), no node inside a lightening hole (hole k
    centred on tooth 0's centre line turned by k 2 pi / holes), nodes on each hole's wall all
    round it; the held nodes only on the bore (no cut faces), every bore node held; the
    contact faces on the fine teeth; gear 2 a solid whole disc. A web over the whole face
    width, holes misplaced or cut faces held would fail."""
    spec = scene.load(REPO / "scenarios" / "fe" / "lightweight_vs_solid_fe.toml", dims=3)
    model = model3d.Model3D(spec, -2, 360.0)   # the mesh study's level (every Jacobian > 0)
    g, sm = model.pair.g1, model.m1
    bd = g.body
    assert bd.web() and bd.holes == 19
    assert sm.sector_teeth == list(range(g.z))
    x, y, z = sm.nodes.T
    R = np.hypot(x, y)
    assert z.min() == pytest.approx(-g.b / 2, abs=1e-12) and z.max() == pytest.approx(g.b / 2)
    web = (R > bd.hub + 1e-9) & (R < bd.rim_inner - 1e-9)
    assert web.sum() > 100
    assert np.abs(z[web] - bd.web_offset).max() <= bd.web_thickness / 2 + 1e-12
    assert np.abs(z[R > bd.rim_inner + 1e-9]).max() == pytest.approx(g.b / 2)
    assert np.abs(z[R < bd.hub - 1e-9]).max() == pytest.approx(g.b / 2)
    for k in range(bd.holes):
        cx = bd.hole_circle * math.cos(2 * math.pi * k / bd.holes)
        cy = bd.hole_circle * math.sin(2 * math.pi * k / bd.holes)
        d = np.hypot(x - cx, y - cy)
        assert d.min() > bd.hole_radius - 1e-9, k
        wall = np.abs(d - bd.hole_radius) < 1e-9
        ang = np.arctan2(y[wall] - cy, x[wall] - cx)
        assert np.diff(np.sort(ang)).max() < 2 * math.pi / 8, k    # nodes all round the hole
    held = np.zeros(len(R), bool)
    held[sm.bore] = True
    on_bore = np.abs(R - g.bore) < 1e-9
    assert np.array_equal(held, on_bore)
    teeth = np.round(np.arctan2(y, x) / g.tau).astype(int) % g.z
    faces_tooth = set(sm.contact_tooth.tolist())
    assert faces_tooth == {k % g.z for k in sm.contact_teeth}
    assert len(set(teeth[R > g.rf]) - set(range(g.z))) == 0
    g2, sm2 = model.pair.g2, model.m2
    assert g2.body.solid()
    assert np.abs(sm2.nodes[:, 2]).max() == pytest.approx(g2.b / 2)
    R2 = np.hypot(sm2.nodes[:, 0], sm2.nodes[:, 1])
    assert np.all(np.abs(R2[sm2.bore] - g2.bore) < 1e-9)
