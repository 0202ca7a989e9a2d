"""3-D mesh of a sector of one gear: 20-node hexahedra (CalculiX C3D20R) by extruding a
recombined quadrilateral mesh of the transverse section along the axis.

* Section (gmsh, OCC): the rack-generated teeth of geometry.py (mesh.add_teeth, the curves of
  the 2-D model) for a run of consecutive teeth, closed by two radial lines at the mid-spaces
  beyond the first and the last tooth down to the bore and the bore's arc; sizes by the 2-D
  model's graded fields (mesh.set_size_fields); all-quadrilateral (Blossom full-quad
  recombination), serendipity 8-node quads with mid-side nodes on the curves.
  Blossom recombination (gmsh's full-quad variants fail on some curves): the few triangles
  left become 15-node wedges (C3D15).
* Extrusion (here, not gmsh): `layers` equal layers over the face width, z from -b/2 to +b/2
  (mid-face at z = 0); each quad8 becomes one hex20 (each tri6 one wedge15), whose vertical
  mid-edge nodes sit on the layer's mid-plane (only the section's corner nodes are repeated
  there).
* Maps of the straight extrusion, applied to every node (mid-side nodes included, so the
  quadratic elements follow the surfaces):
  - lead crowning C_beta (repository docs/model.md, "Micro-geometry": material removed along the flank
    normal, C_beta (2 y / b)^2 with y from mid-face): the section at y is the tooth turned
    towards its centre line by gap / (r_b cos beta_b) on both flanks (an involute offset
    along its normal is the involute turned by offset / r_b, as in geometry.py); inside the
    tooth the turn varies linearly from the centre line (0) to the flanks, in the space between
    teeth back to 0 at mid-space, and fades radially from the form circle to 0 at the root
    circle (the fillet is never in contact), so the map is continuous;
  - helix: the section at z turned about the axis by hand * z tan(beta) / r (r the reference
    radius: a helicoid of lead 2 pi r / tan beta; hand +1 right, -1 left), applied after the
    crowning.
* Contact faces: the hexahedra's faces on flank A (involute) and tip of the fine teeth, every
  layer. Held nodes (`bore`): the nodes on the bore arc and on the two radial cut faces, every
  plane: the cut faces move with the bore (a sector with free cut faces bends as a cantilever
  from its bore arc: about 20 um at 150 N m for set A's 6-tooth sector, three times the
  whole gear's TE; holding them is what a whole disc does far from the load, and the error of
  that is measured against a larger sector).

Element faces (CalculiX C3D20/C3D20R, C3D15): S1 the low-z face, S2 the high-z face, S3.. the
sides on the section edges 1-2, 2-3, ...: a section edge j is face S(j + 2).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from . import mesh
from .geometry import Gear, modified_profile


RECOMBINATION = 1   # gmsh Blossom (the full-quad variants 2, 3 fail on some curves)


@dataclass
class Size3D:
    h_contact: float     # m, on the contact flanks of the fine teeth (section)
    h_tooth: float       # m, elsewhere on the fine teeth
    h_far: float         # m, on the other teeth of the sector
    h_body: float        # m, largest, in the rim and web
    grad: float          # size growth per unit distance
    layers: int          # element layers over the face width
    sector: float        # rad, the sector's angle (whole teeth: fine teeth + equal margins)

    def section(self) -> mesh.MeshSize:
        return mesh.MeshSize(self.h_contact, self.h_tooth, self.h_far, self.h_body, self.grad)


def default_size(m: float, b: float, level: int = 0,
                 sector: float = math.radians(120)) -> Size3D:
    """Sizes at refinement level L: every size / sqrt(2)^L, layers * sqrt(2)^L (level +-1
    changes the element count about 2.8 times; a factor 2 per level, 8x the elements, would
    put level 1 beyond this machine's budget)."""
    f = 2.0 ** (level / 2)
    layers0 = max(4, round(b / (1.5 * m)))
    return Size3D(h_contact=0.18 * m / f, h_tooth=0.4 * m / f, h_far=1.5 * m / f,
                  h_body=4.0 * m / f, grad=0.5, layers=max(2, round(layers0 * f)),
                  sector=sector)


@dataclass
class SolidMesh:
    nodes: np.ndarray          # (n, 3) in the gear's frame, m
    blocks: list               # [(CalculiX type, (e, nodes) 0-based)]: C3D20R hexahedra,
                               # C3D15 wedges where the section kept a triangle
    bore: np.ndarray           # node indices on the bore (every plane)
    contact_faces: np.ndarray  # (f, 2): element index, face number 3..6
    contact_teeth: list[int]
    contact_tooth: np.ndarray  # (f,): the tooth (index mod z) of each contact face
    contact_layer: np.ndarray  # (f,): the element layer (0 at z = -b/2) of each contact face
    sector_teeth: list[int]
    section_nodes: int
    section_quads: int
    section_triangles: int

    @property
    def elements(self):
        raise AttributeError("a solid mesh has element blocks")

    @property
    def stats(self) -> dict:
        return {"nodes": int(len(self.nodes)),
                **{t: int(len(c)) for t, c in self.blocks},
                "section_triangles": self.section_triangles,
                "contact_faces": int(len(self.contact_faces)),
                "section_nodes": self.section_nodes, "section_quads": self.section_quads,
                "sector_teeth": self.sector_teeth, "fine_teeth": self.contact_teeth}


def section(g: Gear, size: Size3D, teeth, fine, hold_cuts=True, verbose=False):
    """Quad8 (and a few tri6) mesh of the sector's transverse section: (xy, [quad8, tri6],
    held node indices (bore arc, and the radial cuts if hold_cuts), contact edges (element,
    edge))."""
    import gmsh

    prof = modified_profile(g)
    with mesh.gmsh_model(f"sector{g.index}", verbose):
        occ = gmsh.model.occ
        ol = mesh.add_teeth(occ, g, prof, teeth, fine, closed=False)
        a0 = (teeth[0] - 0.5) * g.tau
        a1 = (teeth[-1] + 0.5) * g.tau
        am = (a0 + a1) / 2
        q0, qm, q1 = (occ.addPoint(g.bore * math.cos(a), g.bore * math.sin(a), 0.0)
                      for a in (a0, am, a1))
        side1 = occ.addLine(ol.last_point, q1)
        bore_cs = [occ.addCircleArc(q1, ol.centre, qm), occ.addCircleArc(qm, ol.centre, q0)]
        side0 = occ.addLine(q0, ol.first_point)
        loop = occ.addCurveLoop(ol.curves + [side1] + bore_cs + [side0])
        surf = occ.addPlaneSurface([loop])
        occ.synchronize()
        mesh.set_size_fields(size.section(), ol)
        gmsh.option.setNumber("Mesh.Algorithm", 8)              # frontal-Delaunay for quads
        gmsh.option.setNumber("Mesh.RecombinationAlgorithm", RECOMBINATION)
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 1)   # serendipity quad8
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        xy, blocks, index = mesh.surface_elements(surf, (16, 9))
        held = set()
        for c in bore_cs + ([side0, side1] if hold_cuts else []):
            tags, _, _ = gmsh.model.mesh.getNodes(1, c, includeBoundary=True)
            held |= {index[int(t)] for t in tags}
        bore = np.array(sorted(held))
        faces, tooth = mesh.tooth_faces(blocks, index, ol)
        return xy, blocks, bore, faces, tooth


def section_whole(g: Gear, size: Size3D, fine, verbose=False):
    """Quad8 (and a few tri6) mesh of the whole gear's transverse section (every tooth down to
    the bore) and its body: a solid disc, or rim / web / hub regions with the lightening holes
    (g.body). Returns (xy, [quad8, tri6], held node indices (the bore), contact edges,
    their teeth, the region of every section element in block order: 0 rim or disc, 1 web,
    2 hub). The regions share their boundary circles, so the mesh is conforming."""
    import gmsh

    prof = modified_profile(g)
    bd = g.body
    with mesh.gmsh_model(f"whole{g.index}", verbose):
        occ = gmsh.model.occ
        ol = mesh.add_teeth(occ, g, prof, range(g.z), fine, closed=True)
        outer = occ.addCurveLoop(ol.curves)
        bore_c = occ.addCircle(0.0, 0.0, 0.0, g.bore)
        holes = [occ.addCircle(bd.hole_circle * math.cos(2 * math.pi * k / bd.holes),
                               bd.hole_circle * math.sin(2 * math.pi * k / bd.holes), 0.0,
                               bd.hole_radius) for k in range(bd.holes)]
        hole_loops = [occ.addCurveLoop([h]) for h in holes]
        if bd.web():
            rim_c = occ.addCircle(0.0, 0.0, 0.0, bd.rim_inner)
            hub_c = occ.addCircle(0.0, 0.0, 0.0, bd.hub)
            surfs = [occ.addPlaneSurface([outer, occ.addCurveLoop([rim_c])]),
                     occ.addPlaneSurface([occ.addCurveLoop([rim_c]), occ.addCurveLoop([hub_c])]
                                         + hole_loops),
                     occ.addPlaneSurface([occ.addCurveLoop([hub_c]), occ.addCurveLoop([bore_c])])]
            regions = [0, 1, 2]
        else:
            surfs = [occ.addPlaneSurface([outer, occ.addCurveLoop([bore_c])] + hole_loops)]
            regions = [0]
        occ.synchronize()
        extra = []
        if holes:   # at least 16 elements around a hole
            extra.append((holes, min(size.h_body, 2 * math.pi * bd.hole_radius / 16)))
        mesh.set_size_fields(size.section(), ol, extra)
        gmsh.option.setNumber("Mesh.Algorithm", 8)
        gmsh.option.setNumber("Mesh.RecombinationAlgorithm", RECOMBINATION)
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 1)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        parts = [mesh.surface_elements(sf, (16, 9)) for sf in surfs]
        tags = sorted(set().union(*[p[2].keys() for p in parts]))
        index = {t: i for i, t in enumerate(tags)}
        xy = np.zeros((len(tags), 2))
        quads, tris, reg_q, reg_t = [], [], [], []
        for r, (xy_s, (q, t), idx) in zip(regions, parts):
            glob = np.empty(len(idx), dtype=np.int64)
            for tag, i in idx.items():
                glob[i] = index[tag]
            xy[glob] = xy_s
            quads.append(glob[q])
            tris.append(glob[t])
            reg_q += [r] * len(q)
            reg_t += [r] * len(t)
        blocks = [np.vstack(quads), np.vstack(tris)]
        region = np.array(reg_q + reg_t, dtype=np.int64)
        btags, _, _ = gmsh.model.mesh.getNodes(1, bore_c, includeBoundary=True)
        bore = np.array(sorted({index[int(t)] for t in btags}))
        faces, tooth = mesh.tooth_faces(blocks, index, ol)
        far = set()
        for c in ol.far:
            tags, _, _ = gmsh.model.mesh.getNodes(1, c, includeBoundary=False)
            far |= {index[int(t)] for t in tags if int(t) in index}
        straighten_midsides(xy, blocks, far)
        worst = min(float(section_jacobian(xy, c).min()) for c in blocks if len(c))
        if worst <= 0:
            raise RuntimeError(f"gear{g.index}: a section element with a nonpositive Jacobian")
        return xy, blocks, bore, faces, tooth, region


def section_jacobian(xy: np.ndarray, conn: np.ndarray, n: int = 7) -> np.ndarray:
    """Per quad8 / tri6 element the smallest Jacobian determinant over an n x n grid of its
    natural coordinates, corners and edges included (CalculiX refuses an element whose
    Jacobian is nonpositive at an integration point; this looks everywhere)."""
    P = xy[conn]
    worst = np.full(len(conn), np.inf)
    for s in np.linspace(-1.0, 1.0, n):
        for t in np.linspace(-1.0, 1.0, n):
            if conn.shape[1] == 8:       # serendipity quad8: corners, then mid-sides 01 12 23 30
                xi, et = np.array([-1, 1, 1, -1]), np.array([-1, -1, 1, 1])
                ds = np.concatenate([0.25 * xi * (1 + et * t) * (2 * xi * s + et * t),
                                     [-s * (1 - t), 0.5 * (1 - t * t), -s * (1 + t), -0.5 * (1 - t * t)]])
                dt = np.concatenate([0.25 * et * (1 + xi * s) * (xi * s + 2 * et * t),
                                     [-0.5 * (1 - s * s), -t * (1 + s), 0.5 * (1 - s * s), -t * (1 - s)]])
            else:                        # tri6: corners, then mid-sides 01 12 20
                a, b = (s + 1) / 2, (t + 1) / 2 * (1 - (s + 1) / 2)
                l1, l2, l3 = 1 - a - b, a, b
                ds = np.array([1 - 4 * l1, 4 * l2 - 1, 0, 4 * (l1 - l2), 4 * l3, -4 * l3])
                dt = np.array([1 - 4 * l1, 0, 4 * l3 - 1, -4 * l2, 4 * l2, 4 * (l1 - l3)])
            ja = np.einsum("k,ekd->ed", ds, P)
            jb = np.einsum("k,ekd->ed", dt, P)
            worst = np.minimum(worst, ja[:, 0] * jb[:, 1] - ja[:, 1] * jb[:, 0])
    return worst


def straighten_midsides(xy: np.ndarray, blocks, nodes: set) -> None:
    """Move the mid-side nodes among `nodes` to the middle of their edge's corners (in place).
    For the far teeth of a whole gear (never in contact): gmsh puts a coarse element's mid-side
    node on the tooth's spline, which inverts some quadratic elements there (a nonpositive
    Jacobian, refused by CalculiX); a straight edge moves that boundary by microns."""
    if not nodes:
        return
    for conn in blocks:
        if not len(conn):
            continue
        nc = conn.shape[1] // 2
        for j in range(nc):
            mid, a, b = conn[:, nc + j], conn[:, j], conn[:, (j + 1) % nc]
            on = np.fromiter((int(m) in nodes for m in mid), bool, len(mid))
            xy[mid[on]] = (xy[a[on]] + xy[b[on]]) / 2


def layer_planes(b: float, layers: int, body=None) -> np.ndarray:
    """z of the element layers' boundary planes over [-b/2, b/2]: `layers` equal layers, or
    with a web (body.web()) the web's faces as planes: at least 2 layers through the web and
    the rest shared by the parts of the rim either side in proportion to their widths."""
    if body is None or not body.web():
        return np.linspace(-b / 2, b / 2, layers + 1)
    lo = body.web_offset - body.web_thickness / 2
    hi = body.web_offset + body.web_thickness / 2
    parts = [(-b / 2, lo), (lo, hi), (hi, b / 2)]
    out = [-b / 2]
    for j, (a, c) in enumerate(parts):
        if c - a <= 1e-12:
            continue
        n = max(2 if j == 1 else 1, round(layers * (c - a) / b))
        out += list(np.linspace(a, c, n + 1)[1:])
    return np.array(out)


def extrude(xy: np.ndarray, blocks, b: float, layers: int, planes=None):
    """The section's quad8 / tri6 blocks extruded over z in [-b/2, b/2] in `layers` layers into
    hex20 / wedge15 (CalculiX C3D20 / C3D15 node order: bottom corners, top corners, bottom
    mid-sides, top mid-sides, vertical mid-edges): nodes (n, 3), the element blocks (all
    layers of the first section element first), the node index of (plane k, section node)
    on the full planes (z = -b/2 + k b / layers) and of (section node, layer) on the layers'
    mid-planes (-1: not a corner node, no copy there). `planes`: the layers' boundary planes
    (layers + 1 values of z; default equal layers)."""
    corners = np.unique(np.concatenate([c[:, :c.shape[1] // 2].ravel() for c in blocks]))
    n2 = len(xy)
    per = n2 + len(corners)
    if planes is None:
        planes = np.linspace(-b / 2, b / 2, layers + 1)
    z = np.empty(2 * layers + 1)
    z[0::2] = planes
    z[1::2] = (planes[:-1] + planes[1:]) / 2
    full = np.arange(layers + 1)[:, None] * per + np.arange(n2)[None, :]
    corner_pos = np.full(n2, -1)
    corner_pos[corners] = np.arange(len(corners))
    mid = np.arange(layers)[:, None] * per + n2 + np.arange(len(corners))[None, :]
    nodes = np.zeros(((layers + 1) * n2 + layers * len(corners), 3))
    for k in range(layers + 1):
        nodes[full[k]] = np.column_stack([xy, np.full(n2, z[2 * k])])
        if k < layers:
            nodes[mid[k]] = np.column_stack([xy[corners], np.full(len(corners), z[2 * k + 1])])
    out = []
    for conn in blocks:
        nc = conn.shape[1] // 2
        c, m = conn[:, :nc], conn[:, nc:]
        out.append(np.vstack([np.column_stack([full[k][c], full[k + 1][c], full[k][m],
                                               full[k + 1][m], mid[k][corner_pos[c]]])
                              for k in range(layers)]) if len(conn) else
                   np.zeros((0, 5 * nc), dtype=np.int64))
    mid_of = np.where(corner_pos[:, None] >= 0, mid[:, np.maximum(corner_pos, 0)].T, -1)
    return nodes, out, full, mid_of


def crown_map(g: Gear, nodes: np.ndarray, gap_of_z, beta_b: float) -> np.ndarray:
    """Turn each transverse section's teeth towards their centre lines by the lead
    modification gap(z) / (r_b cos beta_b) on the flanks (module doc): returns new nodes."""
    x, y, z = nodes.T
    R = np.hypot(x, y)
    theta = np.arctan2(y, x)
    k = np.round(theta / g.tau)
    psi = theta - k * g.tau                               # from the tooth's centre line
    prof = g.profile
    psi_f = np.interp(np.clip(R, prof.R[0], prof.R[-1]), prof.R, prof.psi)   # flank half angle
    half = g.tau / 2
    a = np.abs(psi)
    w = np.where(a <= psi_f, a / psi_f, np.clip((half - a) / (half - psi_f), 0.0, 1.0))
    fade = np.clip((R - g.rf) / (g.rF - g.rf), 0.0, 1.0)
    turn = np.sign(psi) * w * fade * gap_of_z(z) / (g.rb * math.cos(beta_b))
    t2 = theta - turn
    return np.column_stack([R * np.cos(t2), R * np.sin(t2), z])


def twist_map(g: Gear, nodes: np.ndarray, hand: int) -> np.ndarray:
    """Helicoid: the section at z turned by hand * z tan(beta) / r about the axis."""
    x, y, z = nodes.T
    ang = hand * z * math.tan(g.beta) / g.r
    c, s = np.cos(ang), np.sin(ang)
    return np.column_stack([c * x - s * y, s * x + c * y, z])


def lead_gap(g: Gear, z):
    """Lead modification (m) at axial position z from mid-face: C_beta (2 z / b)^2."""
    return g.mod.lead_crowning * (2 * np.asarray(z) / g.b) ** 2


def build(g: Gear, size: Size3D, fine: list[int], hand: int, beta_b: float,
          hold_cuts: bool = True, verbose=False) -> SolidMesh:
    """The sector of gear g (fine teeth and as many teeth each side as fill size.sector),
    extruded, crowned, twisted; held nodes on the bore and (hold_cuts) the radial cut faces."""
    fine = sorted(fine)
    whole = is_whole(size)
    if whole:
        teeth = list(range(g.z))
        xy, blocks2, bore2, faces2, tooth2, region = section_whole(
            g, size, {k % g.z for k in fine}, verbose)
    else:
        if not g.body.solid():
            raise ValueError(f"gear{g.index}: a web or holes need the whole gear (sector 360 deg)")
        margin = max(1, round((size.sector / g.tau - len(fine)) / 2))
        teeth = list(range(fine[0] - margin, fine[-1] + margin + 1))
        if len(teeth) >= g.z - 1:
            raise ValueError(f"gear{g.index}: a sector of {len(teeth)} teeth is the whole gear "
                             "(sector 360 deg)")
        xy, blocks2, bore2, faces2, tooth2 = section(g, size, teeth, {k % g.z for k in fine},
                                                     hold_cuts, verbose)
        region = np.zeros(sum(len(c) for c in blocks2), dtype=np.int64)
    planes = layer_planes(g.b, size.layers, g.body)
    layers = len(planes) - 1
    nodes, blocks, full, mid_of = extrude(xy, blocks2, g.b, layers, planes)
    if g.body.web():   # the web's elements only between the web's faces
        zc = (planes[:-1] + planes[1:]) / 2
        in_web = np.abs(zc - g.body.web_offset) < g.body.web_thickness / 2
        keep_blocks, old_to_new = [], []
        counts2 = [len(c) for c in blocks2]
        for i, conn in enumerate(blocks):
            reg = region[:counts2[0]] if i == 0 else region[counts2[0]:]
            keep = ((reg[None, :] != 1) | in_web[:, None]).ravel()   # layer-major
            o2n = np.full(len(conn), -1)
            o2n[keep] = np.arange(int(keep.sum()))
            old_to_new.append(o2n)
            keep_blocks.append(conn[keep])
        used = np.unique(np.concatenate([c.ravel() for c in keep_blocks]))
        node_map = np.full(len(nodes), -1)
        node_map[used] = np.arange(len(used))
        nodes = nodes[used]
        blocks = [node_map[c] for c in keep_blocks]
        full = np.where(full >= 0, node_map[full], -1)
        mid_of = np.where(mid_of >= 0, node_map[np.maximum(mid_of, 0)], -1)
    else:
        old_to_new = None
    if g.mod.lead_crowning:
        nodes = crown_map(g, nodes, lambda z: lead_gap(g, z), beta_b)
    if g.beta:
        nodes = twist_map(g, nodes, hand)
    bore_mid = mid_of[bore2]
    bore = np.unique(np.concatenate([full[:, bore2].ravel(), bore_mid[bore_mid >= 0].ravel()]))
    # section element e of block i -> 3-D element (block offset) + layer * count + e
    counts = [len(c) for c in blocks2]
    offs = np.concatenate([[0], np.cumsum([len(c) for c in blocks])])
    faces, tooth, layer = [], [], []
    for (e, j), t in zip(faces2, tooth2):
        i = 0 if e < counts[0] else 1
        local = e - (0 if i == 0 else counts[0])
        for k in range(layers):
            e3 = k * counts[i] + local
            faces.append(((offs[i] + e3) if old_to_new is None
                          else (offs[i] + old_to_new[i][e3]), j + 2))
        tooth += [t] * layers
        layer += list(range(layers))
    if old_to_new is not None and min(f for f, _ in faces) < 0:
        raise RuntimeError("a contact face on a removed element")
    return SolidMesh(nodes=nodes, blocks=[(t, c) for t, c in zip(("C3D20R", "C3D15"), blocks)
                                          if len(c)],
                     bore=bore, contact_faces=np.array(faces), contact_teeth=fine,
                     contact_tooth=np.array(tooth), contact_layer=np.array(layer),
                     sector_teeth=teeth, section_nodes=len(xy), section_quads=counts[0],
                     section_triangles=counts[1])


def is_whole(size: Size3D) -> bool:
    """A sector of 360 deg: the whole gear (no cut faces)."""
    return size.sector >= 2 * math.pi - 1e-9


def size_dict(size: Size3D) -> dict:
    return asdict(size)
