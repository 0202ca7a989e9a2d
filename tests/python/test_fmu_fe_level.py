"""Stiffness level 5 (FE) through the FMU: a scene FMU with two synthetic compliance databases
(.gcdb, core/internal/gearmesh/internal/compliance_db.hpp, written here byte by byte) as resources gear<i>.compliance
evaluates; in single contact the slice force lies below the database's linear bound TE / (2 c)
(the local Hertz law adds compliance) and above half of it; a database for another tooth count is
refused naming gear1.compliance; fmi2GetDirectionalDerivative at level 5 (smooth databases on a
17 x 13 flank grid, +-2 coupled teeth) matches Richardson differences of repeated steps, plain and
quasi-static; a read at a communication point after other inputs were set leaves the next step's
bits unchanged.
"""
from __future__ import annotations

import math
import struct
import zlib

import pytest

from test_fmu_conformance import H, assert_error
from test_fmu_feedthrough import outputs, serialized
from test_fmu_jacobian import check_against_repeated_steps
from test_fmu_microgeometry import Pair
from test_fmu_user_tables import scene_fmu, started

FACE = 0.023
TE = 4e-6
C_TOOTH = 1 / (3.0e10 * FACE)  # m/N: each gear's tooth compliance of the synthetic database


def gcdb(teeth: int = 57, c: float = C_TOOTH, smooth: bool = False) -> bytes:
    """The default gear (paper set A) with a constant compliance c over a 2 x 1 flank grid
    (roll-coupled, so that interpolation keeps it constant); n_c = 2, offsets d != 0 zero."""
    m_n, x, z = 0.0026, 0.35, 57
    d_a = z * m_n + 2 * m_n * (1.0 + x)
    u32 = lambda v: struct.pack("<I", v)
    f64 = lambda v: struct.pack("<d", v)
    note = b"synthetic (test_fmu_fe_level.py)"
    out = b"GMCDB" + u32(1) + u32(teeth) + u32(0)
    for v in (m_n, math.radians(20), 0.0, x, 0.0, FACE, d_a, 1.0, 1.25, 0.38, 210e9, 0.3, 0.03, 1e-3):
        out += f64(v)
    out += u32(2) + u32(1) + f64(1e-3) + u32(len(note)) + note
    if smooth:
        return _smooth_grid(out, c)
    out += u32(1) + u32(1) + u32(2) + u32(1) + u32(2)  # cyclic, mirror, n_roll, n_face, n_c
    out += f64(0.0) + f64(0.03) + f64(0.0)             # roll grid, face grid
    for d in range(-2, 3):
        out += b"".join(f64(c if d == 0 else 0.0) for _ in range(4))
    return out + u32(zlib.crc32(out) & 0xFFFFFFFF)


def _smooth_grid(head: bytes, c: float) -> bytes:
    """A compliance_tool-like grid, as tests/core/fe_synthetic.hpp: 17 roll nodes over 18..36 mm
    (the paper gear's flank from below the start of active profile to beyond the tip, 34.3 mm),
    13 face nodes edge to edge, n_c = 2; C_d = 0.15^|d| c s(rho_a) s(rho_b) exp(-|drho|/3 mm)
    exp(-|dz|/3 mm)/(6 mm) (point-load responses, m/N), s^2 = 0.7 + 0.8 u^2 over the grid
    (u = 0..1)."""
    n_roll, n_face, decay = 17, 13, 3e-3
    roll = [0.018 + 0.018 * a / (n_roll - 1) for a in range(n_roll)]
    face = [-FACE / 2 + FACE * m / (n_face - 1) for m in range(n_face)]
    s = [math.sqrt(0.7 + 0.8 * ((r - roll[0]) / (roll[-1] - roll[0])) ** 2) for r in roll]
    grid = [(a, m) for a in range(n_roll) for m in range(n_face)]
    c0 = [c * s[a] * s[b] * math.exp(-abs(roll[a] - roll[b]) / decay) * math.exp(-abs(face[m] - face[n]) / decay)
          / (2 * decay) for (a, m) in grid for (b, n) in grid]
    out = head + struct.pack("<5I", 1, 1, n_roll, n_face, 2)
    out += struct.pack(f"<{n_roll}d", *roll) + struct.pack(f"<{n_face}d", *face)
    for d in range(-2, 3):
        k = 0.15 ** abs(d)
        out += struct.pack(f"<{len(c0)}d", *(k * v for v in c0))
    return out + struct.pack("<I", zlib.crc32(out) & 0xFFFFFFFF)


@pytest.fixture(scope="module")
def databases(tmp_path_factory):
    d = tmp_path_factory.mktemp("gcdb")
    files = {"g1.gcdb": gcdb(), "g2.gcdb": gcdb(), "z40.gcdb": gcdb(teeth=40),
             "smooth.gcdb": gcdb(c=1 / 3.5e10, smooth=True)}
    for name, data in files.items():
        (d / name).write_bytes(data)
    return {name: d / name for name in files}


def test_level_5_evaluates_with_two_databases(new, fmu_path, tmp_path, databases):
    params = {"model.stiffness": 5, "gear1.compliance": "g1.gcdb", "gear2.compliance": "g2.gcdb"}
    directory, md = scene_fmu(fmu_path, tmp_path, params,
                              {"g1.gcdb": databases["g1.gcdb"], "g2.gcdb": databases["g2.gcdb"]})
    inst, step = started(new, directory, md)
    assert inst.get("model.stiffness") == 5 and inst.get("gear1.compliance") == "g1.gcdb"
    pair = Pair(inst)
    names = ("mesh.normal_force", "mesh.stiffness", "mesh.pairs_in_contact")
    bound = TE / (2 * C_TOOTH)
    for frac in (0.47, 0.5, 0.53):  # single contact
        force, stiffness, pairs = step(pair.pose(pair.phi1(frac * pair.length), TE), names)
        assert pairs == 1
        assert 0.5 * bound < force < bound, frac
        assert 0 < stiffness < 1 / (2 * C_TOOTH), frac


def test_database_of_another_gear_is_named(new, fmu_path, tmp_path, databases):
    params = {"model.stiffness": 5, "gear1.compliance": "z40.gcdb", "gear2.compliance": "g2.gcdb"}
    directory, md = scene_fmu(fmu_path, tmp_path, params,
                              {"z40.gcdb": databases["z40.gcdb"], "g2.gcdb": databases["g2.gcdb"]})
    inst = new(directory=directory, model_description=md)
    inst.slave.setupExperiment(startTime=0.0)
    inst.slave.enterInitializationMode()
    assert_error(inst.slave.exitInitializationMode)
    message = inst.log.messages("logStatusError")[-1]
    assert "gear1.compliance" in message and "z = 40" in message, message


# The reference needs converged coupled solves (solver.tolerance 1e-17 m tightens them; the
# derivative does not use it); quasi-static steps 25x the plain one (test_jacobian.cpp: a lightly
# loaded coupled slice curves strongly, and the solve's floor is low enough for the small step).
FE_CASES = [
    ("level 5 plain", {"model.slices": 5, "solver.tolerance": 1e-17}),
    ("level 5 friction damping plain", {"model.slices": 5, "model.friction_coefficient": 0.05,
                                        "model.friction_velocity": 0.05, "model.damping": 2e3,
                                        "solver.tolerance": 1e-17}),
    ("level 5 quasi-static", {"model.slices": 3, "model.quasi_static": 1, "solver.tolerance": 1e-17}),
]


@pytest.mark.parametrize("name,params", FE_CASES, ids=[c[0] for c in FE_CASES])
def test_level_5_directional_derivative_matches_repeated_steps(fmu_path, tmp_path, databases, name, params):
    scene = {"model.stiffness": 5, "model.coupled_teeth": 2,
             "gear1.compliance": "smooth.gcdb", "gear2.compliance": "smooth.gcdb"}
    directory, md = scene_fmu(fmu_path, tmp_path, scene, {"smooth.gcdb": databases["smooth.gcdb"]})
    check_against_repeated_steps(directory, md, name, params, quasi_step=25.0)


@pytest.mark.parametrize("quasi", [False, True], ids=["plain", "quasi-static"])
def test_level_5_read_at_a_point_leaves_the_next_step_unchanged(new, fmu_path, tmp_path, databases, quasi):
    """Feedthrough at level 5 (docs/fmi.md, "Feedthrough"): outputs read after other inputs were
    set, and directional derivatives, are evaluated on scratch memory, so the coupled solve's warm
    start and kept tangent, where the next step starts, stay the step's: two instances, one of
    which sets other inputs, reads, takes a derivative and sets the step's inputs back, give the
    same bits over the next steps (outputs and FMU state; the derivative on the step's memory
    moved the forces by ~1e-13); the read itself is the evaluation at those inputs (to the
    solve's tolerance)."""
    scene = {"model.stiffness": 5, "model.coupled_teeth": 2, "model.slices": 3,
             "gear1.compliance": "smooth.gcdb", "gear2.compliance": "smooth.gcdb"}
    directory, md = scene_fmu(fmu_path, tmp_path, scene, {"smooth.gcdb": databases["smooth.gcdb"]})
    params = {"model.quasi_static": True} if quasi else {}
    inputs = {"gear1.phi": 1e-4, "gear1.omega": 100.0, "gear2.omega": -100.0, "mesh.load_torque": 200.0}
    a, b = new(directory=directory, model_description=md), new(directory=directory, model_description=md)
    for inst in (a, b):
        inst.initialize(params)
        for t in (0.0, H):
            inst.set({**inputs, "gear1.phi": 1e-4 + 100.0 * t})
            inst.slave.doStep(t, H)
    other = {"gear1.phi": 1.3e-4, "gear2.uy": 1e-6, "mesh.load_torque": 260.0}
    a.set(other)
    read = outputs(a)
    c = new(directory=directory, model_description=md)
    c.initialize(params)
    c.set({**inputs, "gear1.phi": 1e-4 + 100.0 * H, **other})
    c.slave.doStep(0.0, H)
    assert read["mesh.normal_force"] == pytest.approx(outputs(c)["mesh.normal_force"], rel=1e-7)
    assert read["mesh.normal_force"] != outputs(b)["mesh.normal_force"]
    a.slave.getDirectionalDerivative([a.vr("mesh.te")], [a.vr("gear1.phi")], [1.0])
    a.set({**inputs, "gear1.phi": 1e-4 + 100.0 * H, "gear2.uy": 0.0})
    for t in (2 * H, 3 * H):
        for inst in (a, b):
            inst.set({"gear1.phi": 1e-4 + 100.0 * t})
            inst.slave.doStep(t, H)
        assert outputs(a) == outputs(b)
    assert serialized(a) == serialized(b)
