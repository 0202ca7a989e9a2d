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

import math
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


def build(g: Gear, size: MeshSize, fine: list[int], verbose: bool = False) -> GearMesh:
    """Mesh the whole gear g; teeth `fine` (indices, tooth k centred at k 2 pi / z) are the
    refined ones whose flank A and tip form the contact surface."""
    import gmsh

    prof = modified_profile(g)
    z = g.z
    fine = sorted({k % z for k in fine})
    own = not gmsh.isInitialized()
    if own:
        gmsh.initialize(["-noenv"])
    try:
        gmsh.option.setNumber("General.Terminal", 1 if verbose else 0)
        gmsh.model.add(f"gear{g.index}")
        occ = gmsh.model.occ
        contact_curves, fine_curves, far_curves = [], [], []
        centre = occ.addPoint(0.0, 0.0, 0.0)
        first_pt = None   # tooth 0's mid-space root point (flank B side)
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

        for k in range(z):
            is_fine = k in fine
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
                              end=first_pt if k == z - 1 else None)      # form -> root
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
            if is_fine:
                contact_curves += [c_tip, cA_i]
                fine_curves += curves
            else:
                far_curves += curves
        outer = occ.addCurveLoop(loop)
        bore_c = occ.addCircle(0.0, 0.0, 0.0, g.bore)
        hole = occ.addCurveLoop([bore_c])
        surf = occ.addPlaneSurface([outer, hole])
        occ.synchronize()

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

        t1 = graded(contact_curves, 400, size.h_contact)
        t2 = graded(fine_curves, 200, size.h_tooth)
        t3 = graded(far_curves, 60, size.h_far)
        mn = f.add("Min"); f.setNumbers(mn, "FieldsList", [t1, t2, t3])
        f.setAsBackgroundMesh(mn)
        for opt in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints",
                    "Mesh.MeshSizeFromCurvature"):
            gmsh.option.setNumber(opt, 0)
        gmsh.option.setNumber("Mesh.MeshSizeMax", size.h_body)
        gmsh.option.setNumber("Mesh.Algorithm", 6)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)

        tags, coords, _ = gmsh.model.mesh.getNodes()
        etypes, _, enodes = gmsh.model.mesh.getElements(2, surf)
        k9 = list(etypes).index(9)
        tri_tags = enodes[k9].reshape(-1, 6).astype(np.int64)
        used = np.unique(tri_tags)                  # only nodes of elements
        pos = {int(t): i for i, t in enumerate(tags)}
        xy = coords.reshape(-1, 3)[[pos[int(t)] for t in used], :2].copy()
        index = {int(t): i for i, t in enumerate(used)}
        tri = np.searchsorted(used, tri_tags)
        # counter-clockwise corners
        p = xy[tri[:, :3]]
        area2 = ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                 - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
        cw = area2 < 0
        tri[cw] = tri[cw][:, [0, 2, 1, 5, 4, 3]]
        bore_tags, _, _ = gmsh.model.mesh.getNodes(1, bore_c, includeBoundary=True)
        bore = np.array(sorted({index[int(t)] for t in bore_tags}))
        # contact edges: line3 elements of the contact curves -> (triangle, edge)
        edge_of = {}
        for e, t in enumerate(tri):
            for j, (u, v) in enumerate(((t[0], t[1]), (t[1], t[2]), (t[2], t[0]))):
                edge_of[(min(u, v), max(u, v))] = (e, j + 1)
        faces = []
        for c in contact_curves:
            et, _, en = gmsh.model.mesh.getElements(1, c)
            k8 = list(et).index(8)
            for u, v, _mid in en[k8].reshape(-1, 3):
                u, v = index[int(u)], index[int(v)]
                faces.append(edge_of[(min(u, v), max(u, v))])
        return GearMesh(nodes=xy, tri6=tri, bore=bore, contact_faces=np.array(faces),
                        contact_teeth=fine)
    finally:
        gmsh.model.remove()
        if own:
            gmsh.finalize()
