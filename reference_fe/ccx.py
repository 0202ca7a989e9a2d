"""CalculiX (ccx) input deck of the two-gear contact model, the run, and the result parser.

Model (units in the deck: mm, N, MPa, N mm; converted from SI here and only here):

* both gears as CPE6 (plane strain, 6-node triangles; CalculiX expands them into one layer of
  15-node wedges of the face width's thickness with the out-of-plane displacement held);
  plane stress is the same plane-strain model with the exactly equivalent material
  E' = E (1 + 2 nu) / (1 + nu)^2, nu' = nu / (1 + nu) (for isotropic linear elasticity the
  2-D equations of plane stress with (E, nu) are those of plane strain with (E', nu'):
  S. Timoshenko, J. N. Goodier, "Theory of Elasticity", 3rd ed., section 16). Option
  `native_plane_stress` uses CalculiX's own CPS6 instead, for comparison.
* gear 2's bore nodes clamped; gear 1's bore nodes turn rigidly about gear 1's axis with one
  rotation theta, linear multi-point constraints u_x = -theta y, u_y = theta x (*EQUATION; the
  rotation is ~1e-4 rad, the neglected second-order term ~1e-10 m), theta the first DOF of an
  extra node that carries the torque as its force (work-conjugate: sum f . du = M dtheta).
  (CalculiX's own *RIGID BODY, a nonlinear MPC, made the matrix singular once the torque was
  applied to the expanded plane elements: tried, dropped.)
* frictionless (optionally Coulomb) surface-to-surface penalty contact, linear
  pressure-overclosure with slope `penalty` (N/mm^3 in the deck): slave = flank A and tips of
  gear 1's fine teeth, master = the same of gear 2;
* one step per torque (moment about z on the rotation node, totals, not increments); gear 1
  is placed (by the caller) turned a little past the rigid contact so that the contact is
  closed from the first iteration (a rigid body without contact has no static equilibrium
  under a torque); *NODE PRINT of the rotation node's rotation at the end of every increment.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import time
from dataclasses import dataclass

import numpy as np

MM = 1e3  # m -> mm


@dataclass
class Material:
    E: float    # Pa
    nu: float


def plane_stress_equivalent(mat: Material) -> Material:
    """Plane-strain constants that give the plane-stress solution of (E, nu)."""
    return Material(E=mat.E * (1 + 2 * mat.nu) / (1 + mat.nu) ** 2, nu=mat.nu / (1 + mat.nu))


def _fmt_rows(rows, per_line=8):
    out = []
    for r in rows:
        for i in range(0, len(r), per_line):
            out.append(", ".join(str(v) for v in r[i:i + per_line]) +
                       ("," if i + per_line < len(r) else ""))
    return "\n".join(out)


def pre_steps(bodies) -> int:
    """Steps of the deck before the first torque's (3-D: one, at the placement)."""
    return 1 if bodies[0].nodes.shape[1] == 3 else 0


def _contact_surfaces(body, gear_index):
    """[(surface name, faces)]: gear 1's contact faces one surface per tooth (FLANK1_T<k>, the
    slave surfaces whose total contact forces the deck prints), gear 2's one surface FLANK2.
    A 3-D body with `split_layers` set: one surface per tooth and element layer
    (FLANK1_T<k>_Z<j>, layer j from z = -b/2), the contact force per layer (lineload3d.py)."""
    if gear_index == 1:
        return [("FLANK2", body.contact_faces)]
    out = []
    for k in sorted(set(body.contact_tooth.tolist())):
        on = body.contact_tooth == k
        if not getattr(body, "split_layers", False):
            out.append((f"FLANK1_T{k}", body.contact_faces[on]))
            continue
        out += [(f"FLANK1_T{k}_Z{j}", body.contact_faces[on & (body.contact_layer == j)])
                for j in sorted(set(body.contact_layer[on].tolist()))]
    return out


def _blocks(body, element):
    """[(CalculiX element type, connectivity)] of a body: its own blocks (3-D), else one."""
    return getattr(body, "blocks", None) or [(element, body.elements)]


def write_deck(path, bodies, thickness, materials, torques, penalty,
               friction=0.0, element="CPE6"):
    """bodies: two GearMesh-like objects already placed (nodes in the housing frame, m;
    `.elements` in CalculiX's node order, `.bore` node indices, `.contact_faces` (element,
    face number)).

    2-D (nodes (n, 2), CPE6/CPS6): thickness = face width (m). 3-D (nodes (n, 3), e.g. C3D20R):
    thickness None; the bores are held axially too (gear 2's clamped in x, y, z, gear 1's
    u_z = 0 besides the rotation). materials: two Material; torques: N m list (one step
    each; 3-D: after a first step at gear 1's placement, see pre_steps); penalty: pressure per
    overclosure, Pa/m. Returns the number of the rotation node."""
    solid = bodies[0].nodes.shape[1] == 3
    lines = [f"** GearMesh reference_fe: two {'3-D' if solid else 'spur'} gears in contact "
             "(units mm, N, MPa)", "*NODE, NSET=NALL"]
    offsets, eoffsets = [], []
    n0 = e0 = 0
    for b in bodies:
        offsets.append(n0)
        eoffsets.append(e0)
        if solid:
            for i, (x, y, z) in enumerate(b.nodes * MM):
                lines.append(f"{n0 + i + 1}, {x:.12e}, {y:.12e}, {z:.12e}")
        else:
            for i, (x, y) in enumerate(b.nodes * MM):
                lines.append(f"{n0 + i + 1}, {x:.12e}, {y:.12e}, 0.0")
        n0 += len(b.nodes)
        e0 += sum(len(c) for _, c in _blocks(b, element))
    rot = n0 + 1   # carries gear 1's rotation (rad) as its DOF 1, the moment (N mm) as its force
    lines.append(f"{rot}, 0.0, 0.0, 0.0")
    for gi, b in enumerate(bodies):
        e1 = eoffsets[gi]
        for etype, conn in _blocks(b, element):
            lines.append(f"*ELEMENT, TYPE={etype}, ELSET=G{gi + 1}")
            ids = np.arange(len(conn)) + 1 + e1
            lines.append(_fmt_rows(np.column_stack([ids, conn + 1 + offsets[gi]]).tolist(),
                                   per_line=16))
            e1 += len(conn)
    for gi, b in enumerate(bodies):
        lines.append(f"*NSET, NSET=BORE{gi + 1}")
        lines.append(_fmt_rows([(b.bore + 1 + offsets[gi]).tolist()], per_line=16))
        for name, faces in _contact_surfaces(b, gi):
            lines.append(f"*SURFACE, NAME={name}, TYPE=ELEMENT")
            lines += [f"{e + 1 + eoffsets[gi]}, S{j}" for e, j in faces]
    lines += [f"*NSET, NSET=ROT\n{rot}"]
    for gi, mat in enumerate(materials):
        lines += [f"*MATERIAL, NAME=M{gi + 1}", "*ELASTIC", f"{mat.E / 1e6:.9e}, {mat.nu:.9f}",
                  f"*SOLID SECTION, ELSET=G{gi + 1}, MATERIAL=M{gi + 1}"]
        if not solid:
            lines.append(f"{thickness * MM:.9e}")
    # gear 1's bore turns rigidly about the axis: u = theta e_z x r, linear (small rotation:
    # theta ~ 1e-4 rad, the neglected second-order term theta^2 r ~ 1e-10 m)
    lines.append("*EQUATION")
    b = bodies[0]
    for k in b.bore:
        x, y = b.nodes[k, :2] * MM
        n = k + 1 + offsets[0]
        lines += ["2", f"{n}, 1, 1.0, {rot}, 1, {y:.12e}", "2", f"{n}, 2, 1.0, {rot}, 1, {-x:.12e}"]
    lines += ["*SURFACE INTERACTION, NAME=SI",
              "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR",
              f"{penalty / 1e6 / MM:.6e}, 1.0e-3"]
    if friction > 0:
        # stick slope: a tangential stiffness per area of the same order as the penalty
        lines += ["*FRICTION", f"{friction:.6f}, {penalty / 1e6 / MM / 10:.6e}"]
    slaves = [name for name, _ in _contact_surfaces(bodies[0], 0)]
    lines += ["*CONTACT PAIR, INTERACTION=SI, TYPE=SURFACE TO SURFACE"]
    lines += [f"{s}, FLANK2" for s in slaves]
    fixed = (["BORE2, 1, 3", "BORE1, 3, 3", "ROT, 2, 3"] if solid
             else ["BORE2, 1, 2", "ROT, 2, 3"])
    lines += ["*BOUNDARY"] + fixed
    if solid:
        # 3-D: a first step with gear 1's rotation held at the placement (contact closed by
        # the engagement) so that the contact exists when the torque's first iteration comes;
        # a first iteration without contact leaves gear 1 free (singular), and its huge turn
        # lost the contact for good once gear 1's cut faces turn with the bore
        lines += ["*STEP, INC=1000", "*STATIC", "1.0, 1.0, 1e-6, 1.0",
                  "*BOUNDARY", "ROT, 1, 1, 0.0", "*NODE PRINT, NSET=ROT", "U", "*END STEP"]
    for n, T in enumerate(torques):
        lines += ["*STEP, INC=1000", "*STATIC", "1.0, 1.0, 1e-6, 1.0"]
        if solid and n == 0:
            lines += ["*BOUNDARY, OP=NEW"] + fixed
        lines += ["*CLOAD", f"ROT, 1, {T * 1e3:.9e}",
                  "*NODE PRINT, NSET=ROT", "U"]
        for s in slaves:   # the total contact force on each of gear 1's contact teeth
            lines += [f"*CONTACT PRINT, SLAVE={s}, MASTER=FLANK2", "CF"]
        lines.append("*END STEP")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    return rot


@dataclass
class RunResult:
    rotations: list[float]   # rotation of gear 1 (rad) at the end of each step
    contact: list            # (time, gear-1 tooth, |total force| N, moment about z N m)
    contact_layers: list     # (time, tooth, layer, (fx, fy, fz) N, moment about z N m): split
    wall_s: float
    max_rss_MiB: float
    returncode: int
    log_tail: str


def ccx_version() -> str:
    exe = shutil.which("ccx")
    if exe is None:
        return "not installed"
    try:
        out = subprocess.run([exe, "-v"], capture_output=True, text=True, timeout=30).stdout
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    m = re.search(r"[Vv]ersion\s*([0-9.]+)", out)
    return m.group(1) if m else out.strip()[:80]


def run(workdir, job="gears", timeout=3600) -> RunResult:
    """Run ccx on workdir/job.inp single-threaded; wall time and peak resident memory."""
    exe = shutil.which("ccx")
    if exe is None:
        raise RuntimeError("ccx (CalculiX) not found: install the Debian package calculix-ccx "
                           "(tools/bootstrap.sh does)")
    env = dict(os.environ, OMP_NUM_THREADS="1", CCX_NPROC_EQUATION_SOLVER="1",
               CCX_NPROC_RESULTS="1", CCX_NPROC_STIFFNESS="1")
    t0 = time.perf_counter()
    with open(os.path.join(workdir, "ccx.log"), "w") as log:
        proc = subprocess.Popen([exe, "-i", job], cwd=workdir, stdout=log,
                                stderr=subprocess.STDOUT, env=env)
        deadline = t0 + timeout
        while True:
            pid, status, rusage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            if time.perf_counter() > deadline:
                proc.kill()
                pid, status, rusage = os.wait4(proc.pid, 0)
                break
            time.sleep(0.05)
    proc.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - t0
    with open(os.path.join(workdir, "ccx.log")) as f:
        tail = f.read()[-3000:]
    rot = parse_rotations(os.path.join(workdir, job + ".dat"))
    contact = parse_contact_totals(os.path.join(workdir, job + ".dat"))
    layers = parse_contact_layers(os.path.join(workdir, job + ".dat"))
    return RunResult(rotations=rot, contact=contact, contact_layers=layers, wall_s=wall,
                     max_rss_MiB=rusage.ru_maxrss / 1024.0, returncode=proc.returncode,
                     log_tail=tail)


_BLOCK = re.compile(r"displacements \(vx,vy,vz\) for set ROT and time\s+([0-9.Ee+-]+)")
_TOTALS = re.compile(r"statistics for slave set FLANK1_T(\d+), master set FLANK2 and time\s+"
                     r"([0-9.Ee+-]+)")
_LAYERS = re.compile(r"statistics for slave set FLANK1_T(\d+)_Z(\d+), master set FLANK2 and "
                     r"time\s+([0-9.Ee+-]+)")


def _dat_blocks(dat_path, heading: re.Pattern, lookahead: int, columns: int):
    """(heading match, the first row of `columns` numbers within `lookahead` lines after it) of
    every block of a ccx .dat file whose heading matches, in order; [] without the file."""
    if not os.path.exists(dat_path):
        return []
    text = open(dat_path).read().splitlines()
    out = []
    for i, line in enumerate(text):
        hit = heading.search(line)
        if not hit:
            continue
        for row in text[i + 1:i + 1 + lookahead]:
            parts = row.split()
            if len(parts) == columns:
                out.append((hit, parts))
                break
    return out


def parse_rotations(dat_path) -> list[float]:
    """(time, rotation) of the rotation node at the end of every increment, in order."""
    return [(float(hit.group(1)), float(parts[1]))
            for hit, parts in _dat_blocks(dat_path, _BLOCK, 3, 4)]


def parse_contact_totals(dat_path) -> list[tuple[float, int, float, float]]:
    """(time, gear-1 tooth, |total contact force| in N, moment about the z axis through the
    origin (gear 1's axis) in N m) of every *CONTACT PRINT CF block, in order (deck units N,
    mm: "total surface force (fx,fy,fz) and moment about the origin (mx,my,mz)")."""
    out = []
    for hit, parts in _dat_blocks(dat_path, _TOTALS, 4, 6):
        fx, fy, fz, _mx, _my, mz = (float(v) for v in parts)
        out.append((float(hit.group(2)), int(hit.group(1)),
                    float(np.sqrt(fx * fx + fy * fy + fz * fz)), mz / MM))
    return out


def parse_contact_layers(dat_path) -> list[tuple[float, int, int, tuple, float]]:
    """(time, gear-1 tooth, element layer, total contact force (fx, fy, fz) in N, moment about
    the z axis through the origin in N m) of every *CONTACT PRINT CF block of the per-layer
    slave surfaces FLANK1_T<k>_Z<j> (a deck of a body with `split_layers`), in order."""
    out = []
    for hit, parts in _dat_blocks(dat_path, _LAYERS, 4, 6):
        fx, fy, fz, _mx, _my, mz = (float(v) for v in parts)
        out.append((float(hit.group(3)), int(hit.group(1)), int(hit.group(2)),
                    (fx, fy, fz), mz / MM))
    return out
