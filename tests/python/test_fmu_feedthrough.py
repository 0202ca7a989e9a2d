"""Direct feedthrough at a communication point (docs/fmi.md, "Feedthrough"; issue 13, item 6).

An input set after fmi2DoStep changes the outputs read at the same communication point: in the
plain and quasi-static modes they are the evaluation at the current inputs (what a fresh
instance gives there), in the large-step mode the contact at the integrated spin state and the
current pose. Such a read leaves what the next fmi2DoStep computes unchanged, bit for bit. The
ModelStructure declares exactly the output/known pairs that respond, over the three modes.
Before this, every test here failed: the outputs changed only at the next fmi2DoStep while
every output was declared to depend on every input.
"""
from __future__ import annotations

import math

import pytest
from fmpy.fmi1 import FMICallException

from test_fmu_conformance import H

W = 100.0  # rad/s

# A loaded mesh where every input acts: a helical pair (axial forces) at level 4 (stiffness
# varying along the path, an iterative force solve), friction and damping (velocities), tilts
# and displacements (pose), three slices.
COMMON = {"pair.helix_angle": math.radians(10), "pair.center_distance": 0.1523, "model.stiffness": 4,
          "model.slices": 3, "model.friction_coefficient": 0.05, "model.friction_velocity": 0.05,
          "model.damping": 2e3, "solver.tolerance": 1e-15}
POSE = {"gear1.ux": 1e-6, "gear1.uy": -2e-6, "gear1.uz": 3e-5, "gear1.rx": 1e-4, "gear1.ry": -5e-5,
        "gear2.ux": -1e-6, "gear2.uy": 1.5e-6, "gear2.uz": -2e-5, "gear2.rx": -8e-5, "gear2.ry": 6e-5,
        "gear1.vx": 0.01, "gear1.vy": -0.02, "gear1.vz": 0.005, "gear1.wx": 0.2, "gear1.wy": -0.1,
        "gear2.vx": -0.015, "gear2.vy": 0.01, "gear2.vz": -0.01, "gear2.wx": 0.1, "gear2.wy": 0.3,
        "gear1.phi": 5e-4, "gear2.phi": -1e-4, "gear1.omega": W, "gear2.omega": -0.99 * W}
MODES = {
    "plain": ({}, {}),
    "quasi-static": ({"model.quasi_static": True}, {"mesh.load_torque": 300.0}),
    "large-step": ({"model.dynamics": 1, "gear1.shaft_stiffness": 1e4, "gear1.shaft_damping": 1.0,
                    "gear2.shaft_stiffness": 2e4, "gear2.shaft_damping": 2.0},
                   {"gear1.shaft_phi": 0.012, "gear1.shaft_omega": W, "gear2.torque": 150.0,
                    "gear2.shaft_phi": -0.011, "gear2.shaft_omega": -0.99 * W, "gear1.torque": 20.0}),
}
# A perturbation per input kind, small enough to stay on the contact set of the point.
DELTA = {"u": 1e-8, "r": 1e-6, "phi": 1e-7, "v": 1e-3, "w": 1e-2, "omega": 0.1, "load_torque": 1.0,
         "torque": 1.0, "shaft_phi": 1e-5, "shaft_omega": 0.1}


def delta(name: str) -> float:
    tail = name.split(".")[1]
    return DELTA.get(tail, DELTA.get(tail[0]))


def outputs(inst) -> dict:
    """Every output by name (Real and Integer)."""
    real = [v.name for v in inst.md.modelVariables if v.causality == "output" and v.type == "Real"]
    integer = [v.name for v in inst.md.modelVariables if v.causality == "output" and v.type == "Integer"]
    values = (inst.slave.getReal([inst.vr(n) for n in real])
              + inst.slave.getInteger([inst.vr(n) for n in integer]))
    return dict(zip(real + integer, values))


def start(new, mode: str, inputs: dict | None = None, init_only: bool = False):
    """An instance of the mode at the test point, stepped twice (or left in Initialization Mode)."""
    params, extra = MODES[mode]
    inst = new()
    inst.slave.setupExperiment(startTime=0.0)
    inst.set({**COMMON, **params})
    inst.slave.enterInitializationMode()
    inst.set({**POSE, **extra, **(inputs or {})})
    if init_only:
        return inst
    inst.slave.exitInitializationMode()
    inst.slave.doStep(0.0, H)
    inst.slave.doStep(H, H)
    return inst


def responses(inst, mode: str) -> set:
    """(output, input) pairs where moving the input alone, at this point, changes the output."""
    point = {**POSE, **MODES[mode][1]}
    inputs = [v.name for v in inst.md.modelVariables if v.causality == "input"]
    moved = set()
    base = None
    for name in inputs:
        x = point.get(name, 0.0)
        inst.set({name: x + delta(name)})
        y = outputs(inst)
        inst.set({name: x})
        y0 = outputs(inst)  # evaluated again at the point (the input was moved)
        assert base is None or y0 == base, f"{name}: the same inputs gave other outputs"
        base = y0
        moved |= {(out, name) for out in y if y[out] != y0[out]}
    return moved


def parameter_responses(inst, mode: str) -> set:
    """(unknown, parameter) pairs in Initialization Mode where moving a numeric parameter alone
    changes an output or calculated parameter; moves the model refuses are skipped."""
    unknowns = [v.name for v in inst.md.modelVariables if v.causality in ("output", "calculatedParameter")]
    params = {**COMMON, **MODES[mode][0]}
    moved = set()
    for v in inst.md.modelVariables:
        if v.causality != "parameter" or v.type not in ("Real", "Integer"):
            continue
        x = params.get(v.name, float(v.start) if v.type == "Real" else int(v.start))
        step = 1 if v.type == "Integer" else (abs(x) * 1e-6 or 1e-9)
        y0 = {n: inst.get(n) for n in unknowns}
        inst.set({v.name: x + step})
        try:
            y = {n: inst.get(n) for n in unknowns}
        except FMICallException:
            y = y0  # outside the allowed range here: nothing to measure
        inst.set({v.name: x})
        moved |= {(n, v.name) for n in unknowns if y[n] != y0[n]}
    return moved


def declared(md, element: str) -> set:
    return {(u.variable.name, k.name) for u in getattr(md, element) for k in u.dependencies}


# Discrete and solver outputs: their declared knowns can act (a contact event, another iteration
# count, the residual's rounding) but need not at a given point; checked as a subset only.
SUBSET_ONLY = {"mesh.pairs_in_contact", "mesh.flank", "solver.iterations", "solver.residual"}


@pytest.mark.parametrize("element", ["outputs", "initialUnknowns"])
def test_model_structure_is_what_the_binary_does(new, md, element):
    """Every input a declared output depends on moves it in at least one mode (at a loaded,
    tilted, sliding, damped helical point), and no undeclared input moves any output in any
    mode: in <Outputs> at a communication point after two steps, in <InitialUnknowns> in
    Initialization Mode. Parameters, knowns of the InitialUnknowns by class: none outside its
    declared classes moves an unknown."""
    init = element == "initialUnknowns"
    moved = set()
    for mode in MODES:
        inst = start(new, mode, init_only=init)
        moved |= responses(inst, mode)
        if init:
            moved |= parameter_responses(inst, mode)
    inputs = {v.name for v in md.modelVariables if v.causality == "input"}
    want = declared(md, element)
    assert moved - want == set(), "undeclared pairs respond"
    exact = {(u, k) for u, k in want if k in inputs and u not in SUBSET_ONLY}
    assert exact - moved == set(), "declared pairs do not respond in any mode"


def fresh_init(new, mode: str, inputs: dict) -> dict:
    """The outputs of a new instance initialized at the point with inputs changed."""
    inst = start(new, mode, inputs, init_only=True)
    inst.slave.exitInitializationMode()
    return outputs(inst)


@pytest.mark.parametrize("mode,name,value", [("plain", "gear1.phi", 5.5e-4),
                                             ("quasi-static", "mesh.load_torque", 600.0)])
def test_an_input_set_after_a_step_is_read_at_the_same_point(new, mode, name, value):
    """Set after fmi2DoStep and read at once: the outputs are those of a new instance
    initialized at those inputs (plain: the same bits; quasi-static: the TE solved from another
    warm start, to 1e-9, in another number of iterations), not the step's."""
    inst = start(new, mode)
    before = outputs(inst)
    inst.set({name: value})
    after = outputs(inst)
    assert after["mesh.te"] != before["mesh.te"] and after["gear1.mz"] != before["gear1.mz"]
    fresh = fresh_init(new, mode, {name: value})
    if mode == "plain":
        assert after == fresh
    else:
        del after["solver.iterations"], fresh["solver.iterations"]
        assert after == pytest.approx(fresh, rel=1e-9, abs=1e-15)
        assert after["gear2.mz"] == pytest.approx(-value, rel=1e-3)  # equal radii: the load's reaction


def test_a_contact_event_at_the_point_is_read_too(new):
    """The discrete outputs feed through as well: gear 1 turned back by 20 um of TE opens the
    mesh at the same communication point."""
    inst = start(new, "plain")
    assert outputs(inst)["mesh.pairs_in_contact"] > 0
    r_b1 = 0.5 * inst.get("gear1.base_diameter")
    inst.set({"gear1.phi": POSE["gear1.phi"] - 2e-5 / r_b1})
    y = outputs(inst)
    assert (y["mesh.pairs_in_contact"], y["mesh.flank"], y["mesh.normal_force"]) == (0, 0, 0.0)


def test_large_step_reads_the_contact_at_the_spin_state_and_the_current_pose(new):
    """Large-step mode: a new pose acts on the contact outputs at once, which are then those of
    the plain element at the integrated spins and that pose; the drive inputs act only over the
    next step (the spin state, shaft torques, energy account and the last step's means stay)."""
    inst = start(new, "large-step")
    before = outputs(inst)
    inst.set({"gear1.torque": 500.0, "gear1.shaft_phi": 0.02, "gear2.shaft_omega": 0.0, "gear1.phi": 0.1})
    assert outputs(inst) == before
    inst.set({"gear2.uy": POSE["gear2.uy"] + 1e-6})
    after = outputs(inst)
    # (the step means are the last step's: a pose set at the point does not rewrite them)
    state = {n: before[n] for n in before if n.startswith(("energy.", "dynamics.")) or n.endswith(
        ("angle", "speed", "shaft_torque", "_mean", "_min", "_max", "_rms"))}
    assert {n: after[n] for n in state} == state
    assert after["gear2.fy"] != before["gear2.fy"]
    spins = {f"gear{i}.{k}": before[f"gear{i}.{o}"] for i in (1, 2) for k, o in (("phi", "angle"), ("omega", "speed"))}
    # the plain element with the contact damping the large-step mode adds (dynamics.mesh_damping_ratio)
    damping = COMMON["model.damping"] + inst.slave.getReal([inst.vr("dynamics.mesh_damping")])[0]
    assert damping > COMMON["model.damping"]
    plain = fresh_init(new, "plain", {**spins, "gear2.uy": POSE["gear2.uy"] + 1e-6, "model.damping": damping})
    contact = [v.name for v in inst.md.modelVariables if v.causality == "output" and v.name not in state]
    assert {n: after[n] for n in contact} == {n: plain[n] for n in contact}


@pytest.mark.parametrize("mode", ["plain", "quasi-static"])
def test_set_get_iteration_at_a_point_converges_to_the_fixed_point(new, mode):
    """An algebraic loop closed by the master at one communication point: gear 2's centre on a
    bearing of stiffness k, gear2.uy = -gear2.fy / k. Fixed-point iteration of set/get converges
    geometrically (contraction ~ mesh stiffness / k) to the u at which a new instance gives
    -k u back; with outputs that change only at the next step it stopped after one iteration
    at a u 1e-7 m off."""
    k = 2e9  # N/m
    inst = start(new, mode)
    u, steps = POSE["gear2.uy"], []
    for _ in range(60):
        inst.set({"gear2.uy": u})
        u_next = -outputs(inst)["gear2.fy"] / k
        steps.append(abs(u_next - u))
        u = u_next
        if steps[-1] <= 1e-16:
            break
    assert 3 <= len(steps) < 60, steps
    assert all(b < 0.6 * a for a, b in zip(steps[:3], steps[1:4])), steps  # contracts from the start
    check = fresh_init(new, mode, {"gear2.uy": u})
    assert abs(u + check["gear2.fy"] / k) <= 1e-14 + 1e-9 * abs(u)


def serialized(inst) -> bytes:
    state = inst.slave.getFMUstate()
    blob = inst.slave.serializeFMUstate(state)
    inst.slave.freeFMUstate(state)
    return bytes(blob)


@pytest.mark.parametrize("mode", list(MODES))
def test_a_read_at_the_point_leaves_the_next_step_unchanged(new, mode):
    """Two instances at the same point; one sets other inputs, reads every output (and, where
    there are derivatives, a directional derivative), then sets the step's inputs again. The
    next two steps give the same bits in both, outputs and FMU state: the read evaluates on
    scratch memory (quasi-static warm start, level 5's coupled solve) and leaves the TE jump
    check's reference alone."""
    a, b = start(new, mode), start(new, mode)
    point = {**POSE, **MODES[mode][1]}
    moved = {n: x + 50 * delta(n) for n, x in point.items()}
    a.set(moved)
    assert outputs(a) != outputs(b)
    a.slave.getDirectionalDerivative([a.vr("mesh.te")], [a.vr("gear1.phi"), a.vr("gear2.uy")], [1.0, 1.0])
    a.set(point)
    for t in (2 * H, 3 * H):
        for inst in (a, b):
            inst.set({"gear1.phi": point["gear1.phi"] + W * t})
            inst.slave.doStep(t, H)
        assert outputs(a) == outputs(b)
    assert serialized(a) == serialized(b)
