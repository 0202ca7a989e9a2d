"""2-D quadratic triangle mesh of one complete gear (all teeth down to the bore) with gmsh.

The outline is the rack-generated tooth of geometry.py (with the gear's profile modifications),
repeated z times; each flank's fillet and involute and each tip are separate curves (OCC
interpolating splines through the generated points), so the contact flanks can be picked by
curve. Element sizes (a background field, the minimum of three thresholds):

* the contact flanks (flank A involute and tip of the `fine` teeth): `h_contact` on the curve,
  growing by `grad` per unit distance up to `h_tooth`;
* every curve of the fine teeth (fillets, flank B): `h_tooth`, growing to `h_body`;
* every other tooth: `h_far` at its outline, growing to `h_body`.

Six-node triangles (gmsh type 9), mid-side nodes on the curves. Node order of gmsh's
triangle6 (corners, then the mid-sides of edges 1-2, 2-3, 3-1) is CalculiX's CPE6/CPS6 order.
"""
from __future__ import annotations

import contextlib
from dataclasses import dataclass

import numpy as np

from .geometry import Gear, HalfProfile, modified_profile


@dataclass
class MeshSize:
    h_contact: float   # m, on the contact flanks of the fine teeth
    h_tooth: float     # m, elsewhere on the fine teeth
    h_far: float       # m, on the other teeth
    h_body: float      # m, largest, in the body
    grad: float = 0.4   # size growth per unit distance

    def refined(self, factor: float) -> "MeshSize":
        return MeshSize(self.h_contact / factor, self.h_tooth / factor, self.h_far / factor,
                        self.h_body / factor, self.grad)


def default_size(m: float, level: int = 0) -> MeshSize:
    """Mesh sizes in modules at refinement level L: h / 2^L (level 1 halves every size,
    level -1 doubles it)."""
    base = MeshSize(h_contact=0.03 * m, h_tooth=0.2 * m, h_far=0.8 * m, h_body=2.5 * m,
                    grad=0.4)
    return base.refined(2.0 ** level) if level else base


@dataclass
class GearMesh:
    nodes: np.ndarray          # (n, 2) coordinates in the gear's frame, m (tooth 0 along +x)
    tri6: np.ndarray           # (e, 6) node indices (0-based), counter-clockwise
    bore: np.ndarray           # node indices on the bore
    contact_faces: np.ndarray  # (f, 2): element index, edge number 1..3 (1: nodes 1-2, ...)
    contact_teeth: list[int]
    contact_tooth: np.ndarray  # (f,): the tooth (index mod z) of each contact face

    @property
    def elements(self) -> np.ndarray:
        return self.tri6

    @property
    def stats(self) -> dict:
        return {"nodes": int(len(self.nodes)), "tri6": int(len(self.tri6)),
                "contact_edges": int(len(self.contact_faces))}


def _tooth_points(prof: HalfProfile, angle: float, stride: int):
    """Flank B (root to tip), flank A (tip to root) points of the tooth centred at `angle`,
    the involute start index; fewer points (every stride-th) on a coarse tooth."""
    n = len(prof.R)
    iF = int(np.argmax(prof.involute))
    keep = np.unique(np.concatenate([np.arange(0, iF + 1, stride), [iF],
                                     np.arange(iF, n, stride), [n - 1]]))
    R, psi = prof.R[keep], prof.psi[keep]
    iF = int(np.searchsorted(keep, iF))
    return R, psi, iF


@dataclass
class Outline:
    """gmsh (OCC) curves of consecutive teeth, from the mid-space root point before the first
    tooth (flank B side) to the one after the last; curve tags by role."""
    curves: list[int]
    contact: list[int]     # flank A involute and tip of the fine teeth
    contact_tooth: list[int]  # the tooth (index mod z) of each contact curve
    fine: list[int]        # every curve of the fine teeth
    far: list[int]         # every curve of the other teeth
    first_point: int
    last_point: int
    centre: int            # a point at the gear's axis


def add_teeth(occ, g: Gear, prof: HalfProfile, teeth, fine, closed: bool) -> Outline:
    """Add the outline of teeth `teeth` (consecutive indices, tooth k centred at k 2 pi / z) of
    gear g to the OCC model; `closed`: the last tooth's root joins the first's (whole gear)."""
    teeth = list(teeth)
    contact_curves, contact_tooth, fine_curves, far_curves = [], [], [], []
    centre = occ.addPoint(0.0, 0.0, 0.0)
    first_pt = None   # the first tooth's mid-space root point (flank B side)
    prev_pt = None    # the previous tooth's mid-space root point (flank A side)
    loop = []

    def add_points(xs, ys, start=None, end=None):
        """Point tags along (xs, ys); the first/last replaced by existing tags if given."""
        tags = []
        for j, (x, y) in enumerate(zip(xs, ys)):
            if j == 0 and start is not None:
                tags.append(start)
            elif j == len(xs) - 1 and end is not None:
                tags.append(end)
            else:
                tags.append(occ.addPoint(float(x), float(y), 0.0))
        return tags

    for n, k in enumerate(teeth):
        is_fine = k % g.z in fine
        R, psi, iF = _tooth_points(prof, k * g.tau, 1 if is_fine else 4)
        c = k * g.tau
        xb, yb = R * np.cos(c - psi), R * np.sin(c - psi)      # flank B, root -> tip
        xa, ya = R * np.cos(c + psi), R * np.sin(c + psi)      # flank A, root -> tip
        pB_f = add_points(xb[:iF + 1], yb[:iF + 1], start=prev_pt)
        if first_pt is None:
            first_pt = pB_f[0]
        pB_i = add_points(xb[iF:], yb[iF:], start=pB_f[-1])
        pA_i = add_points(xa[iF:][::-1], ya[iF:][::-1])                 # tip -> form
        pA_f = add_points(xa[:iF + 1][::-1], ya[:iF + 1][::-1], start=pA_i[-1],
                          end=first_pt if closed and n == len(teeth) - 1 else None)
        prev_pt = pA_f[-1]
        cB_f = occ.addSpline(pB_f)
        cB_i = occ.addSpline(pB_i)
        c_tip = occ.addCircleArc(pB_i[-1], centre, pA_i[0])
        cA_i = occ.addSpline(pA_i)
        cA_f = occ.addSpline(pA_f)
        curves = [cB_f, cB_i, c_tip, cA_i, cA_f]
        # interior spline points are free vertices of the OCC model (they would get nodes)
        inner = [t for pl in (pB_f, pB_i, pA_i, pA_f) for t in pl[1:-1]]
        occ.remove([(0, t) for t in inner])
        loop += curves
        if is_fine:   # the loaded flank: A (+psi), a ring's B (-psi)
            contact_curves += [c_tip, cB_i if getattr(g, "contact_flank", "A") == "B" else cA_i]
            contact_tooth += [k % g.z] * 2
            fine_curves += curves
        else:
            far_curves += curves
    return Outline(curves=loop, contact=contact_curves, contact_tooth=contact_tooth,
                   fine=fine_curves, far=far_curves, first_point=first_pt, last_point=prev_pt,
                   centre=centre)


def set_size_fields(size: MeshSize, outline: Outline, extra=()):
    """The background size field: the minimum of the three graded thresholds (module doc) and
    of `extra` ones, (curves, size on them) growing alike (the 3-D model's lightening holes)."""
    import gmsh

    f = gmsh.model.mesh.field

    def graded(curves, sampling, h_near):
        """A size field: h_near on the curves, growing at size.grad to size.h_body."""
        d = f.add("Distance")
        f.setNumbers(d, "CurvesList", curves)
        f.setNumber(d, "Sampling", sampling)
        t = f.add("Threshold")
        f.setNumber(t, "InField", d)
        f.setNumber(t, "SizeMin", h_near)
        f.setNumber(t, "SizeMax", size.h_body)
        f.setNumber(t, "DistMin", 0.0)
        f.setNumber(t, "DistMax", (size.h_body - h_near) / size.grad)
        return t

    fields = [graded(outline.contact, 400, size.h_contact),
              graded(outline.fine, 200, size.h_tooth)]
    if outline.far:
        fields.append(graded(outline.far, 60, size.h_far))
    fields += [graded(curves, 100, h) for curves, h in extra]
    mn = f.add("Min"); f.setNumbers(mn, "FieldsList", fields)
    f.setAsBackgroundMesh(mn)
    for opt in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints",
                "Mesh.MeshSizeFromCurvature"):
        gmsh.option.setNumber(opt, 0)
    gmsh.option.setNumber("Mesh.MeshSizeMax", size.h_body)


_CORNERS = {6: 3, 8: 4}   # triangle6, quad8


def edge_faces(blocks, index: dict, curves) -> np.ndarray:
    """(element, edge number 1..corners) of the line3 mesh elements on `curves`; elements
    numbered over the blocks in order; edge j joins corner j and j+1 (the CalculiX face
    numbering of CPE6/CPS6 and of the sides of a triangle or quad)."""
    import gmsh

    edge_of = {}
    e0 = 0
    for conn in blocks:
        corners = _CORNERS[conn.shape[1]] if len(conn) else 0
        for e, t in enumerate(conn):
            for j in range(corners):
                u, v = t[j], t[(j + 1) % corners]
                edge_of[(min(u, v), max(u, v))] = (e0 + e, j + 1)
        e0 += len(conn)
    faces = []
    for c in curves:
        et, _, en = gmsh.model.mesh.getElements(1, c)
        k8 = list(et).index(8)
        for u, v, _mid in en[k8].reshape(-1, 3):
            u, v = index[int(u)], index[int(v)]
            faces.append(edge_of[(min(u, v), max(u, v))])
    return np.array(faces)


def tooth_faces(blocks, index: dict, outline: Outline) -> tuple[np.ndarray, np.ndarray]:
    """The contact faces (edge_faces of the outline's contact curves) and the tooth of each,
    tooth by tooth (the reference's per-tooth contact forces, ccx.write_deck)."""
    faces, tooth = [], []
    for k in sorted(set(outline.contact_tooth)):
        curves = [c for c, t in zip(outline.contact, outline.contact_tooth) if t == k]
        f = edge_faces(blocks, index, curves)
        faces.append(f)
        tooth += [k] * len(f)
    return np.concatenate(faces), np.array(tooth)


# gmsh element type -> reversed node order: the same element clockwise
_FLIP = {9: [0, 2, 1, 5, 4, 3],                  # triangle6
         16: [0, 3, 2, 1, 7, 6, 5, 4]}           # quad8 (serendipity)


def surface_elements(surf: int, gmsh_types):
    """The mesh of surface `surf`: node coordinates (n, 2) of the nodes of its elements only,
    one connectivity per gmsh type asked for (0-based, corners counter-clockwise; empty if
    none) and the map gmsh tag -> index. Other element types are an error."""
    import gmsh

    tags, coords, _ = gmsh.model.mesh.getNodes()
    etypes, _, enodes = gmsh.model.mesh.getElements(2, surf)
    extra = set(int(t) for t in etypes) - set(gmsh_types)
    if extra:
        raise RuntimeError(f"surface {surf}: element types {sorted(extra)} not expected")
    by_type = {int(t): en for t, en in zip(etypes, enodes)}
    el_tags = [by_type[t].reshape(-1, len(_FLIP[t])).astype(np.int64) if t in by_type
               else np.zeros((0, len(_FLIP[t])), dtype=np.int64) for t in gmsh_types]
    used = np.unique(np.concatenate([e.ravel() for e in el_tags]))  # only nodes of elements
    pos = {int(t): i for i, t in enumerate(tags)}
    xy = coords.reshape(-1, 3)[[pos[int(t)] for t in used], :2].copy()
    index = {int(t): i for i, t in enumerate(used)}
    blocks = []
    for t, et in zip(gmsh_types, el_tags):
        conn = np.searchsorted(used, et)
        # counter-clockwise corners (signed area of the first three corners; convex elements)
        p = xy[conn[:, :3]]
        area2 = ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                 - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
        cw = area2 < 0
        conn[cw] = conn[cw][:, _FLIP[t]]
        blocks.append(conn)
    return xy, blocks, index


@contextlib.contextmanager
def gmsh_model(name: str, verbose: bool = False):
    """A gmsh model named `name` for the block (gmsh initialized for it unless it already
    is); removed afterwards, gmsh finalized again if this started it."""
    import gmsh

    own = not gmsh.isInitialized()
    if own:
        gmsh.initialize(["-noenv"])
    try:
        gmsh.option.setNumber("General.Terminal", 1 if verbose else 0)
        gmsh.model.add(name)
        yield
    finally:
        gmsh.model.remove()
        if own:
            gmsh.finalize()


def build(g: Gear, size: MeshSize, fine: list[int], verbose: bool = False) -> GearMesh:
    """Mesh the whole gear g; teeth `fine` (indices, tooth k centred at k 2 pi / z) are the
    refined ones whose flank A and tip form the contact surface. An internal ring
    (geometry.RingGear): the annulus from its teeth out to the clamped outer circle (`bore`
    nodes), flank B and tips the contact surface, body sizes at most a third of the rim."""
    import gmsh

    prof = modified_profile(g)
    z = g.z
    fine = sorted({k % z for k in fine})
    ring = getattr(g, "internal", False)
    if ring:   # the ring's body between its root circle and the clamped outer circle
        size = MeshSize(size.h_contact, size.h_tooth, size.h_far,
                        min(size.h_body, (g.bore - g.rf) / 3), size.grad)
    with gmsh_model(f"gear{g.index}", verbose):
        occ = gmsh.model.occ
        ol = add_teeth(occ, g, prof, range(z), fine, closed=True)
        teeth_loop = occ.addCurveLoop(ol.curves)
        bore_c = occ.addCircle(0.0, 0.0, 0.0, g.bore)   # a ring: its clamped outer circle
        circle_loop = occ.addCurveLoop([bore_c])
        surf = occ.addPlaneSurface([circle_loop, teeth_loop] if ring
                                   else [teeth_loop, circle_loop])
        occ.synchronize()
        set_size_fields(size, ol)
        gmsh.option.setNumber("Mesh.Algorithm", 6)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)

        xy, (tri,), index = surface_elements(surf, (9,))
        bore_tags, _, _ = gmsh.model.mesh.getNodes(1, bore_c, includeBoundary=True)
        bore = np.array(sorted({index[int(t)] for t in bore_tags}))
        faces, tooth = tooth_faces([tri], index, ol)
        return GearMesh(nodes=xy, tri6=tri, bore=bore, contact_faces=faces,
                        contact_teeth=fine, contact_tooth=tooth)
