"""Which tooth pairs the 2-D reference gives contact surfaces (reference_fe/analysis.py,
fine_teeth and contact_set_check) and the tip corners' rigid gap past the path of contact
(reference_fe/geometry.py, Pair.tip_corner_gap).

The gap is checked against the geometry's own definitions (zero where the corner leaves the path
of contact, quadratic growth past it, slower on the conforming internal pair) and against the
core's contact detection through the FMU (no code shared): in plain mode at a prescribed TE the
leaving pair's normal approach is the TE less the gap."""
from __future__ import annotations


import pytest

from reference_fe import analysis, geometry, scene
from conftest import REPO

RING = REPO / "scenarios" / "fe" / "internal_ring_fe.toml"
SET_A = REPO / "scenarios" / "paper_setA_3U4U.toml"


def end_turn(pair: geometry.Pair) -> float:
    """Gear 1's turn from position 0 at which tooth 0 leaves the path of contact."""
    return (pair.rho_tip1 - pair.rho_pitch1) / pair.g1.rb


@pytest.mark.parametrize("path", [RING, SET_A])
def test_corner_gap_is_zero_at_the_path_end_and_opens_quadratically(path):
    pair = geometry.Pair(scene.load(path))
    t_end = end_turn(pair)
    assert pair.tip_corner_gap(t_end, 0) < 0.01e-6   # the TE is read to 0.01 um
    step = 0.05 * pair.pb / pair.g1.rb
    g1, g2 = pair.tip_corner_gap(t_end + step, 0), pair.tip_corner_gap(t_end + 2 * step, 0)
    assert 0 < g1 < g2
    assert 3.6 < g2 / g1 < 4.4   # quadratic in the turn past the end
    # before the end the flank, not the corner, carries: the corner stands off the mate's flank
    assert pair.tip_corner_gap(t_end - 2 * step, 0) > 0


def test_internal_pair_gap_opens_slowest():
    """The ring's flanks conform (concave against convex), so at the same share of a base pitch
    past the end its corner gap is about half the external set A's."""
    ring, ext = geometry.Pair(scene.load(RING)), geometry.Pair(scene.load(SET_A))
    s = 0.15
    g_ring = ring.tip_corner_gap(end_turn(ring) + s * ring.pb / ring.g1.rb, 0)
    g_ext = ext.tip_corner_gap(end_turn(ext) + s * ext.pb / ext.g1.rb, 0)
    assert g_ring < 0.6 * g_ext


def test_corner_gap_matches_the_cores_detection(fmu_path):
    """The FMU in plain mode at the ring's geometry, gear 2 placed for a TE of 20 um: the pair
    past the end of the path (mesh.pair_position 1) has the normal approach TE - gap, the gap
    from the reference's outlines, within 0.3 um (the approach is along the mate's flank
    normal, a few degrees off the line of action there)."""
    from gearmesh.fmu_driver import GearMeshFMU
    from gearmesh.prescribed_motion import pair_kinematics
    from gearmesh.scene import load_scene

    sc = load_scene(RING, fmu_path)
    params = {k: v for k, v in sc.parameters.items() if not k.startswith("gear") or
              not k.endswith("compliance")}
    params.update({"model.stiffness": 3, "model.friction_coefficient": 0.0})
    pair = geometry.Pair(scene.load(RING))
    te = 20e-6
    checked = 0
    with GearMeshFMU(fmu_path, params, instance_name="corner_gap") as fmu:
        kin = pair_kinematics(fmu)
        n = fmu.get(["model.slices"])["model.slices"]
        base = array_bases(fmu_path)
        for k in (17, 18, 19, 20):
            phi1 = k / 20 * pair.g1.tau
            fmu.step({"gear1.phi": phi1, "gear2.phi": kin.phi2(te, phi1)})
            pairs = int(fmu.get(["mesh.pairs_in_contact"])["mesh.pairs_in_contact"])
            pos = fmu.fmu.getReal([base["mesh.pair_position"] + i for i in range(pairs)])
            app = fmu.fmu.getReal([base["mesh.pair_approach"] + i for i in range(pairs)])
            gap = pair.tip_corner_gap(phi1, 0)
            last = max(range(pairs), key=lambda i: pos[i])
            assert pos[last] == pytest.approx(1.0)
            assert abs(app[last] - (te - gap)) < 0.3e-6, (k, app[last], te - gap)
            checked += 1
        assert n > 0
    assert checked == 4


def array_bases(fmu_path) -> dict:
    """The first value reference of each array output (modelDescription's Array elements)."""
    import re
    import zipfile
    xml = zipfile.ZipFile(fmu_path).read("modelDescription.xml").decode()
    return {m[0]: int(m[1]) for m in re.findall(r'<Array name="([^"]+)" elementBase="(\d+)"', xml)}


class _Result:
    def __init__(self, position, dphi1, te):
        self.position, self.dphi1, self.te = position, dphi1, [te]


def test_contact_set_check_names_a_left_out_tooth_that_could_touch():
    """The ring at the default margin leaves out gear 1's tooth 1, whose corner gap at
    position 0 (0.18 base pitch past the path's end) is about 9.8 um: a TE of 16.5 um there (the
    reference's at 100 N m with it left out) is flagged, 5 um is not; the margin of 0.5 base
    pitch takes the tooth in."""
    pair = geometry.Pair(scene.load(RING))
    teeth, _ = analysis.fine_teeth(pair)
    assert max(teeth) == 0
    gap = pair.tip_corner_gap(0.0, 1)
    assert 9.0e-6 < gap < 10.5e-6
    flagged = analysis.contact_set_check(pair, teeth, [_Result(0, 0.0, 16.5e-6)])
    assert [(f["position"], f["tooth_gear1"], f["end"]) for f in flagged] == [(0, 1, "leaving")]
    assert analysis.contact_set_check(pair, teeth, [_Result(0, 0.0, 5e-6)]) == []
    wide, _ = analysis.fine_teeth(pair, margin=0.5)
    assert 1 in wide
    assert analysis.contact_set_check(pair, wide, [_Result(0, 0.0, 16.5e-6)]) == []


def test_contact_set_check_takes_a_helical_pairs_face_ends():
    """With a spread (a helical pair's face ends stand that much roll either side of the
    mid-face section) the check takes the smallest gap of the three sections: a TE between the
    mid-face gap and the face end's is flagged only with the spread."""
    pair = geometry.Pair(scene.load(SET_A))
    teeth, _ = analysis.fine_teeth(pair)
    mid = pair.tip_corner_gap(0.0, 1)
    spread = 0.05 * pair.pb
    end = pair.tip_corner_gap(-spread / pair.g1.rb, 1)
    assert end < mid
    te = 0.5 * (end + mid)
    assert analysis.contact_set_check(pair, teeth, [_Result(0, 0.0, te)]) == []
    flagged = analysis.contact_set_check(pair, teeth, [_Result(0, 0.0, te)], spread=spread)
    assert [(f["tooth_gear1"], f["end"]) for f in flagged] == [(1, "leaving")]
