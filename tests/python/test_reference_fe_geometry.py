"""reference_fe's rack-generated tooth against the core's geometry (read from the FMU's
calculated parameters with fmpy; no code shared) and against the involute's closed form.

Tolerances: base and tip diameter 1e-9 relative (the same closed forms); form diameter 0.01 um
(the generated round's tangency point, found from the rack, against the core's d_Ff); backlash
0.05 um (from the generated outline's thicknesses at the operating pitch circles, interpolated
between generated points 0.03 mm apart: measured 0.013 um on set A); contact ratio 1e-9; the
generated flank against the involute 0.01 um; the meshed contact flank (mid-side nodes too)
against the generated outline 0.05 um (the TE is read to 0.01 um, so the mesh must not move
the flank by more than a few hundredths of a micron)."""
from __future__ import annotations

import math

import numpy as np
import pytest


from reference_fe import geometry, mesh, scene  # noqa: E402
from conftest import REPO

SCENES = ["paper_setA_3U4U.toml", "paper_setB_P1P2.toml"]


def fmu_geometry(fmu_path, spec: scene.PairSpec) -> dict:
    """The core's calculated geometry parameters for the scene's pair (fmpy, FMI 2.0)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu_path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzip = extract(str(fmu_path))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzip,
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="geometry")
    fmu.instantiate()
    try:
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        real = {"pair.center_distance": spec.center_distance,
                "pair.normal_module": spec.module,
                "pair.pressure_angle": spec.pressure_angle,
                "pair.rack_addendum": spec.rack_addendum,
                "pair.rack_dedendum": spec.rack_dedendum,
                "pair.rack_tip_radius": spec.rack_tip_radius}
        for i in (1, 2):
            g = spec.gear(i)
            real.update({f"gear{i}.profile_shift": g.shift, f"gear{i}.face_width": g.face_width,
                         f"gear{i}.tip_diameter": g.tip_diameter,
                         f"gear{i}.thickness_allowance": g.thickness_allowance})
        fmu.setReal([vr[k] for k in real], list(real.values()))
        fmu.setInteger([vr["gear1.teeth"], vr["gear2.teeth"]], [spec.gear1.teeth, spec.gear2.teeth])
        if spec.internal:   # level 4 refuses a ring; the geometry is the same at every level
            fmu.setBoolean([vr["pair.internal"]], [True])
            fmu.setInteger([vr["model.stiffness"]], [3])
        fmu.exitInitializationMode()
        names = [v.name for v in md.modelVariables if v.causality == "calculatedParameter"]
        values = fmu.getReal([vr[n] for n in names])
        fmu.terminate()
    finally:
        fmu.freeInstance()
    return dict(zip(names, values))


@pytest.mark.parametrize("scene_file", SCENES)
def test_generated_tooth_matches_core_geometry(fmu_path, scene_file):
    spec = scene.load(REPO / "scenarios" / scene_file)
    pair = geometry.Pair(spec)
    core = fmu_geometry(fmu_path, spec)
    for i, g in ((1, pair.g1), (2, pair.g2)):
        assert 2 * g.rb == pytest.approx(core[f"gear{i}.base_diameter"], rel=1e-9)
        assert 2 * g.ra == pytest.approx(core[f"gear{i}.tip_diameter_used"], rel=1e-9)
        assert abs(2 * g.rF - core[f"gear{i}.form_diameter"]) < 1e-8
    assert abs(pair.backlash() - core["geometry.backlash"]) < 0.05e-6
    assert pair.eps_alpha == pytest.approx(core["geometry.contact_ratio"], rel=1e-9)
    assert pair.alpha_wt == pytest.approx(core["geometry.operating_pressure_angle"], rel=1e-9)
    assert pair.pb == pytest.approx(core["geometry.base_pitch"], rel=1e-9)


@pytest.mark.parametrize("scene_file", SCENES)
def test_generated_flank_is_the_involute(scene_file):
    spec = scene.load(REPO / "scenarios" / scene_file)
    for g in geometry.Pair(spec).g1, geometry.Pair(spec).g2:
        p = g.profile
        on = p.involute
        err = (p.psi[on] - g.involute_psi(p.R[on])) * p.R[on]
        assert np.abs(err).max() < 0.01e-6
        # the fillet stays inside the involute's extension and above the root circle
        assert p.R.min() == pytest.approx(g.rf, rel=1e-12)
        assert np.all(np.diff(p.psi) <= 1e-15)   # the half thickness shrinks to the tip


def test_crowning_moves_the_flank_by_the_gap():
    """Set B's gear 2 (C_alpha = 10 um): the modified flank lies C_alpha (2s/L - 1)^2 inside
    the involute along its normal (= r_b times the angle), 10 um at the SAP and the tip."""
    spec = scene.load(REPO / "scenarios" / "paper_setB_P1P2.toml")
    pair = geometry.Pair(spec)
    g = pair.g2
    mod = geometry.modified_profile(g)
    normal = (g.profile.psi - mod.psi) * g.rb
    for R, want in ((g.ra, 10e-6), (math.hypot(g.rb, g.rho_sap), 10e-6),
                    (math.hypot(g.rb, (g.rho_sap + g.rho_tip) / 2), 0.0)):
        got = float(np.interp(R, g.profile.R, normal))
        assert got == pytest.approx(want, abs=0.02e-6)


def test_meshed_contact_flank_lies_on_the_outline():
    spec = scene.load(REPO / "scenarios" / "paper_setA_3U4U.toml")
    g = geometry.Pair(spec).g1
    coarse = mesh.MeshSize(h_contact=0.1 * spec.module, h_tooth=0.4 * spec.module,
                           h_far=1.5 * spec.module, h_body=5 * spec.module)
    gm = mesh.build(g, coarse, [0])
    nodes = set()
    for e, j in gm.contact_faces:
        t = gm.tri6[e]
        nodes.update({1: (t[0], t[3], t[1]), 2: (t[1], t[4], t[2]), 3: (t[2], t[5], t[0])}[j])
    xy = gm.nodes[sorted(nodes)]
    R = np.hypot(xy[:, 0], xy[:, 1])
    ang = np.arctan2(xy[:, 1], xy[:, 0])          # tooth 0 is centred on +x
    flank = R < g.ra - 1e-9
    assert flank.sum() > 20
    err = (ang[flank] - g.involute_psi(R[flank])) * R[flank]
    assert np.abs(err).max() < 0.05e-6
    # the bore: every bore node on the bore circle
    rb = np.hypot(*gm.nodes[gm.bore].T)
    assert np.allclose(rb, g.bore, rtol=1e-9)
    assert g.bore == pytest.approx(0.4 * g.rf)


def test_plane_stress_equivalent_material():
    """Plane stress with (E, nu) = plane strain with (E', nu'): plane strain's effective
    E'/(1 - nu'^2) and nu'/(1 - nu') must be E and nu (Timoshenko & Goodier, section 16)."""
    from reference_fe import ccx

    for E, nu in ((210e9, 0.3), (70e9, 0.33), (1e9, 0.0)):
        eq = ccx.plane_stress_equivalent(ccx.Material(E, nu))
        assert eq.E / (1 - eq.nu ** 2) == pytest.approx(E, rel=1e-14)
        assert eq.nu / (1 - eq.nu) == pytest.approx(nu, rel=1e-14, abs=1e-15)


RING = REPO / "scenarios" / "fe" / "internal_ring_fe.toml"


def test_ring_matches_core_geometry(fmu_path):
    """The internal ring pair (ISO 21771's signed convention of internal gears, generated here
    from the scene's keys) against the core's calculated geometry: the ring's tip (inner)
    diameter, both base diameters, the contact ratio, the operating pressure angle, the base
    pitch and the backlash (the ring's space less the pinion's tooth). The form diameters
    differ on purpose: both rings have a circular-arc root fillet, of radius rho_fP m here."""
    spec = scene.load(RING)
    pair = geometry.Pair(spec)
    core = fmu_geometry(fmu_path, spec)
    for i, g in ((1, pair.g1), (2, pair.g2)):
        assert 2 * g.rb == pytest.approx(core[f"gear{i}.base_diameter"], rel=1e-9)
        assert 2 * g.ra == pytest.approx(core[f"gear{i}.tip_diameter_used"], rel=1e-9)
    assert abs(2 * pair.g1.rF - core["gear1.form_diameter"]) < 1e-8
    assert pair.eps_alpha == pytest.approx(core["geometry.contact_ratio"], rel=1e-9)
    assert pair.alpha_wt == pytest.approx(core["geometry.operating_pressure_angle"], rel=1e-9)
    assert pair.pb == pytest.approx(core["geometry.base_pitch"], rel=1e-9)
    assert abs(pair.backlash() - core["geometry.backlash"]) < 0.05e-6


def test_ring_flank_is_the_space_involute():
    """The ring tooth's flank: half angle pi/z minus the space's involute half angle
    e/(2r) + inv(alpha) - inv(alpha_R) (an independent closed form: the space is an external
    involute tooth of thickness e = pi m - s); the fillet tangent to the flank and the root
    circle with radius rho_fP m; the meshed contact flank (flank B) on it; the clamped nodes
    on the outer circle; at position 0 both flanks through the pitch point (-r_w1, 0)."""
    spec = scene.load(RING)
    pair = geometry.Pair(spec)
    g = pair.g2
    p = g.profile
    on = p.involute
    inv = np.tan(g.alpha) - g.alpha
    aR = np.arccos(g.rb / p.R[on])
    want = math.pi / g.z - (g.e / (2 * g.r) + inv - (np.tan(aR) - aR))
    assert np.abs((p.psi[on] - want) * p.R[on]).max() < 1e-12
    assert p.R.max() == pytest.approx(g.rf, rel=1e-12) and p.R[on].min() == pytest.approx(g.ra)
    # the fillet: every fillet point at rho_fP m from one centre on the circle r_f - rho
    rho = spec.rack_tip_radius * spec.module
    fil = (~on) & (p.R < g.rf - 1e-12)
    xy = np.column_stack([p.R[fil] * np.cos(p.psi[fil]), p.R[fil] * np.sin(p.psi[fil])])
    centre = xy.mean(axis=0)
    for _ in range(50):   # least squares centre of the arc
        d = np.hypot(*(xy - centre).T)
        centre = centre + ((xy - centre) * (1 - rho / d)[:, None]).mean(axis=0)
    assert np.abs(np.hypot(*(xy - centre).T) - rho).max() < 1e-9
    assert np.hypot(*centre) == pytest.approx(g.rf - rho, rel=1e-6)
    coarse = mesh.MeshSize(h_contact=0.1 * spec.module, h_tooth=0.4 * spec.module,
                           h_far=1.5 * spec.module, h_body=5 * spec.module)
    gm = mesh.build(g, coarse, [0])
    nodes = set()
    for e, j in gm.contact_faces:
        t = gm.tri6[e]
        nodes.update({1: (t[0], t[3], t[1]), 2: (t[1], t[4], t[2]), 3: (t[2], t[5], t[0])}[j])
    xy = gm.nodes[sorted(nodes)]
    R = np.hypot(xy[:, 0], xy[:, 1])
    ang = np.arctan2(xy[:, 1], xy[:, 0])
    flank = R > g.ra + 1e-9
    assert flank.sum() > 20
    assert np.all(ang[flank] < 0)           # flank B: the -psi side of tooth 0
    assert np.abs((-ang[flank] - g.involute_psi(R[flank])) * R[flank]).max() < 0.05e-6
    assert np.allclose(np.hypot(*gm.nodes[gm.bore].T), spec.gear2.body.ring_outer, rtol=1e-9)
    phi1, phi2 = pair.rotations(0.0)
    a1 = phi1 + pair.g1.psi_at(pair.rw1)
    a2 = phi2 - g.psi_at(pair.rw2)
    assert (pair.rw1 * math.cos(a1), pair.rw1 * math.sin(a1)) == pytest.approx((-pair.rw1, 0), abs=1e-12)
    assert (pair.a + pair.rw2 * math.cos(a2), pair.rw2 * math.sin(a2)) == pytest.approx(
        (-pair.rw1, 0), abs=1e-12)
