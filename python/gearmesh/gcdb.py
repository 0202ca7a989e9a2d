"""Read a compliance database (.gcdb, version 1) into numpy arrays, and reduce it to the
face-uniform line-load kernel of the tooth coupling (docs/model.md, "Tooth coupling at level 4").

The format is core/internal/gearmesh/internal/compliance_db.hpp's; this reader checks the magic,
the version, the CRC-32 and the declared sizes, not every range (the core's reader does).
"""
from __future__ import annotations

import pathlib
import struct
import zlib

import numpy as np

_SCALARS = ("normal_module", "pressure_angle", "helix_angle", "profile_shift",
            "thickness_allowance", "face_width", "tip_diameter", "rack_addendum",
            "rack_dedendum", "rack_tip_radius", "youngs_modulus", "poisson_ratio",
            "bore_radius", "mesh_size")


class GcdbError(ValueError):
    """The file is not a readable version-1 compliance database; the message says why."""


def read_gcdb(path: pathlib.Path | str) -> dict:
    """The database's fields (compliance_db.hpp's names); 'blocks' is an array
    [tooth set * flank sets * (2 n_c + 1), n_grid, n_grid] (receiver row, load column)."""
    data = pathlib.Path(path).read_bytes()
    if data[:5] != b"GMCDB":
        raise GcdbError(f"{path}: not a compliance database (magic)")
    if len(data) < 9 or zlib.crc32(data[:-4]) != struct.unpack_from("<I", data, len(data) - 4)[0]:
        raise GcdbError(f"{path}: checksum mismatch (corrupt or truncated)")
    pos = 5

    def take(fmt):
        nonlocal pos
        value = struct.unpack_from(fmt, data, pos)[0]
        pos += struct.calcsize(fmt)
        return value

    db: dict = {"version": take("<I")}
    if db["version"] != 1:
        raise GcdbError(f"{path}: version {db['version']}, this reader reads version 1")
    db["teeth"] = take("<I")
    db["internal"] = take("<I")
    for name in _SCALARS:
        db[name] = take("<d")
    db["mesh_order"] = take("<I")
    db["mesh_face_layers"] = take("<I")
    db["depth"] = take("<d")
    n = take("<I")
    db["note"] = data[pos:pos + n].decode("utf-8", "replace")
    pos += n
    for name in ("cyclic", "mirror", "n_roll", "n_face", "n_coupled"):
        db[name] = take("<I")
    nr, nf, nc = db["n_roll"], db["n_face"], db["n_coupled"]
    db["roll"] = np.frombuffer(data, "<f8", nr, pos).copy()
    pos += 8 * nr
    db["face"] = np.frombuffer(data, "<f8", nf, pos).copy()
    pos += 8 * nf
    sets = (1 if db["cyclic"] else db["teeth"]) * (1 if db["mirror"] else 2) * (2 * nc + 1)
    ng = nr * nf
    if pos + 8 * sets * ng * ng + 4 != len(data):
        raise GcdbError(f"{path}: declared sizes do not match the file's length")
    db["blocks"] = np.frombuffer(data, "<f8", sets * ng * ng, pos).reshape(sets, ng, ng)
    return db


def face_weights(db: dict) -> np.ndarray:
    """Tributary width of each face node (strips end half-way between nodes and at the faces), m."""
    z = db["face"]
    half = 0.5 * db["face_width"]
    edges = np.concatenate([[-half], 0.5 * (z[1:] + z[:-1]), [half]])
    return np.diff(edges)


def line_kernels(db: dict, tooth_set: int = 0, flank_set: int = 0) -> dict[int, np.ndarray]:
    """E k_d[a, b] for d = -n_c..n_c: the face-averaged normal displacement of tooth d at roll
    node a under a face-uniform unit line load (N/m) on tooth 0 at roll node b, times Young's
    modulus (dimensionless; k_d itself is m^2/N)."""
    nr, nf, nc = db["n_roll"], db["n_face"], db["n_coupled"]
    w = face_weights(db)
    b = db["face_width"]
    fs = 1 if db["mirror"] else 2
    out = {}
    for d in range(-nc, nc + 1):
        block = db["blocks"][(tooth_set * fs + flank_set) * (2 * nc + 1) + d + nc]
        c = block.reshape(nr, nf, nr, nf)
        out[d] = db["youngs_modulus"] * np.einsum("m,ambn,n->ab", w / b, c, w)
    return out


def roll_heights(db: dict) -> np.ndarray:
    """Height of each roll node above the reference circle in normal modules,
    h = (sqrt(rho^2 + r_b^2) - r) / m_n (transverse radii)."""
    mn, z = db["normal_module"], db["teeth"]
    beta = db["helix_angle"]
    alpha_t = np.arctan(np.tan(db["pressure_angle"]) / np.cos(beta))
    r = z * mn / (2 * np.cos(beta))
    rb = r * np.cos(alpha_t)
    return (np.sqrt(db["roll"] ** 2 + rb ** 2) - r) / mn
