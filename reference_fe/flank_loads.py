"""One gear alone, linear and plane strain: its response at depth below the contact flank of
teeth -n..n to a unit line load on tooth 0's contact flank, with CalculiX (CPE6).

What a compliance database holds (repository compliance_tool/README.md), from a model that
shares no code with it: the same gear outline (geometry.py), meshed by mesh.py with the contact
teeth refined, the body clamped where the tool clamps it (the bore; a ring's outer circle), a
nodal force normal to the flank at the flank node nearest each load point, one static step per
load, and the displacement along the flank's inward normal read at depth h (linear interpolation
between the nodes around the point). Tooth k is centred at k 2 pi / z, counter-clockwise; the
contact flank is the gear's `contact_flank` (a ring's: the clockwise side of its teeth).
"""
from __future__ import annotations

import math
import pathlib
import re
import tempfile

import numpy as np

from . import ccx, mesh
from .geometry import Pair
from .scene import PairSpec

_FORCE = 1e4  # N per metre of face (the model's thickness is 1 m); the answers are per unit load


def flank_point(g, tooth: int, roll: float) -> tuple[np.ndarray, np.ndarray]:
    """The contact flank's point at roll distance `roll` on tooth `tooth` and its unit normal
    into the tooth (gear frame, m)."""
    tau = 2 * math.pi / g.z
    centre = tooth * tau
    R = math.hypot(roll, g.rb)

    def at(radius):
        th = Pair._flank_angle(g, centre, radius)
        return np.array([radius * math.cos(th), radius * math.sin(th)])

    p = at(R)
    e = 1e-7 * g.m
    top = max(g.ra, g.rF)   # the involute runs between the form and the tip circle
    t = at(R + e) - p if R + e <= top else p - at(R - e)
    t /= np.linalg.norm(t)
    n = np.array([-t[1], t[0]])
    axis = np.array([math.cos(centre), math.sin(centre)])   # the tooth's centre line
    if n.dot(R * axis - p) < 0:
        n = -n
    return p, n


def responses(spec: PairSpec, gear: int, load_rolls, receiver_rolls, depth: float, teeth: int = 2,
              level: int = 0, workdir: str | None = None) -> np.ndarray:
    """k[i, d + teeth, a] (m^2/N): the normal displacement at depth `depth` below roll
    receiver_rolls[a] of tooth d's contact flank per unit line load (N/m) normal to tooth 0's
    contact flank at load_rolls[i]; gear 1 or 2 of the scene's pair."""
    from scipy.interpolate import LinearNDInterpolator

    pair = Pair(spec)
    g = pair.g1 if gear == 1 else pair.g2
    model = mesh.build(g, mesh.default_size(spec.module, level), list(range(-teeth, teeth + 1)))
    X = model.nodes
    points = [(d, a, *flank_point(g, d, r)) for d in range(-teeth, teeth + 1)
              for a, r in enumerate(receiver_rolls)]
    probes = np.array([p + depth * n for (_, _, p, n) in points])
    near = np.unique(np.concatenate([np.flatnonzero(np.linalg.norm(X - q, axis=1) < 3 * depth)
                                     for q in probes]))
    lines = ["*HEADING", "reference_fe flank_loads", "*NODE"]
    lines += [f"{i + 1}, {x:.12e}, {y:.12e}" for i, (x, y) in enumerate(X)]
    lines += ["*ELEMENT, TYPE=CPE6, ELSET=EALL"]
    lines += [f"{e + 1}, " + ", ".join(str(v + 1) for v in el) for e, el in enumerate(model.elements)]
    lines += ["*MATERIAL, NAME=STEEL", "*ELASTIC", f"{g.E:.9e}, {g.nu}",
              "*SOLID SECTION, ELSET=EALL, MATERIAL=STEEL", "1.0"]
    for name, ids in (("FIX", model.bore), ("NOUT", near)):
        lines += [f"*NSET, NSET={name}"]
        lines += [", ".join(str(v + 1) for v in ids[i:i + 16]) for i in range(0, len(ids), 16)]
    lines += ["*BOUNDARY", "FIX, 1, 2"]
    for r in load_rolls:
        p, n = flank_point(g, 0, r)
        node = int(np.argmin(np.linalg.norm(X - p, axis=1)))
        if np.linalg.norm(X[node] - p) > 0.05 * g.m:
            raise ValueError(f"no flank node within 0.05 m_n of roll {r} m (nearest "
                             f"{np.linalg.norm(X[node] - p):.3g} m off)")
        lines += ["*STEP", "*STATIC", "*CLOAD, OP=NEW", f"{node + 1}, 1, {_FORCE * n[0]:.12e}",
                  f"{node + 1}, 2, {_FORCE * n[1]:.12e}", "*NODE PRINT, NSET=NOUT", "U", "*END STEP"]
    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        work = pathlib.Path(tmp)
        (work / "loads.inp").write_text("\n".join(lines) + "\n")
        result = ccx.run(str(work), "loads")
        if result.returncode != 0:
            raise RuntimeError(f"ccx failed ({result.returncode}): {result.log_tail[-500:]}")
        text = (work / "loads.dat").read_text()
    blocks = re.split(r"displacements \(vx,vy,vz\) for set NOUT and time\s+\S+", text)[1:]
    if len(blocks) != len(load_rolls):
        raise RuntimeError(f"ccx printed {len(blocks)} displacement blocks for {len(load_rolls)} loads")
    out = np.zeros((len(load_rolls), 2 * teeth + 1, len(receiver_rolls)))
    for i, block in enumerate(blocks):
        rows = [line.split() for line in block.strip().splitlines() if re.match(r"^\s*\d", line)]
        ids = np.array([int(row[0]) - 1 for row in rows])
        U = np.array([[float(row[1]), float(row[2])] for row in rows]) / _FORCE
        field = LinearNDInterpolator(X[ids], U)
        for (d, a, _, n), q in zip(points, probes):
            out[i, d + teeth, a] = field(q)[0].dot(n)
    return out
