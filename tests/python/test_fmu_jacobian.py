"""fmi2GetDirectionalDerivative through fmpy (FMU2Slave.getDirectionalDerivative) against
finite differences of a repeated communication step (fmi2GetFMUstate / fmi2SetFMUstate, the
inputs moved along the direction, fmi2DoStep again): every Real output, along random input
directions, plain and quasi-static; the derivative belongs to the current inputs, as the outputs
read do; parameters as knowns are refused with a message naming them."""
from __future__ import annotations

import random

import pytest
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave

H = 1e-5  # communication step, s
W = 100.0  # rad/s

# A direction scale per input: the finite-difference step is 1e-5 of it (~1e-8 relative; lightly
# loaded Hertz slices curve strongly), 1e-3 in quasi-static mode (see below).
SCALE = {"u": 1e-5, "r": 1e-3, "phi": 1e-3, "v": 0.1, "w": 1.0, "omega": 10.0, "load_torque": 100.0}
STEP = 1e-5


def kind(name: str) -> str:
    tail = name.split(".")[1]
    tail = {"shaft_phi": "phi", "shaft_omega": "omega", "torque": "load_torque"}.get(tail, tail)
    for k in ("load_torque", "omega", "phi"):
        if tail == k:
            return k
    return tail[0]


class Fmu:
    def __init__(self, fmu_dir, md, params: dict):
        self.vars = {v.name: v for v in md.modelVariables}
        self.inputs = [v.name for v in md.modelVariables if v.causality == "input"]
        # solver.residual's derivative is reported as 0 (solver noise, not a function of the inputs)
        self.outputs = [v.name for v in md.modelVariables
                        if v.causality == "output" and v.type == "Real" and v.name != "solver.residual"]
        self.s = FMU2Slave(guid=md.guid, unzipDirectory=str(fmu_dir), modelIdentifier="GearMesh",
                           instanceName="jac")
        self.s.instantiate()
        self.s.setupExperiment(startTime=0.0)
        self.set(params)
        self.s.enterInitializationMode()
        self.s.exitInitializationMode()

    def vr(self, names):
        return [self.vars[n].valueReference for n in names]

    def set(self, values: dict):
        for name, x in values.items():
            v = self.vars[name]
            setter = {"Integer": self.s.setInteger, "Boolean": self.s.setBoolean}.get(v.type, self.s.setReal)
            setter([v.valueReference], [x])

    def out(self):
        return self.s.getReal(self.vr(self.outputs))

    def free(self):
        self.s.terminate()
        self.s.freeInstance()


def pose(rng: random.Random, quasi: bool) -> dict:
    x = {}
    for g in (1, 2):
        for a in "xyz":
            x[f"gear{g}.u{a}"] = 4e-6 * rng.uniform(-1, 1)
            x[f"gear{g}.v{a}"] = 0.05 * rng.uniform(-1, 1)
        for a in "xy":
            x[f"gear{g}.r{a}"] = 2e-4 * rng.uniform(-1, 1)
            x[f"gear{g}.w{a}"] = 0.5 * rng.uniform(-1, 1)
    x["gear1.phi"] = 1e-4 + 0.11 * rng.random()
    x["gear2.phi"] = -x["gear1.phi"] + (0.0 if quasi else 3e-5 * rng.random())  # equal radii (57/57)
    x["gear1.omega"] = W
    x["gear2.omega"] = -W * (1 + 0.01 * rng.uniform(-1, 1))
    x["mesh.load_torque"] = 300 + 500 * rng.random() if quasi else 0.0
    return x


# The reference needs converged solves (solver.tolerance); the derivative itself does not use it.
CASES = [
    ("level 0 plain", {"solver.tolerance": 1e-15}),
    ("level 4 friction damping plain", {"model.stiffness": 4, "model.slices": 5,
                                        "model.friction_coefficient": 0.05, "model.friction_velocity": 0.05,
                                        "model.damping": 2e3, "solver.tolerance": 1e-15}),
    ("level 2 quasi-static", {"model.stiffness": 2, "model.slices": 3, "model.quasi_static": 1,
                              "solver.tolerance": 1e-15}),
]


@pytest.mark.parametrize("name,params", CASES, ids=[c[0] for c in CASES])
def test_directional_derivative_matches_repeated_steps(fmu_dir, md, name, params):
    check_against_repeated_steps(fmu_dir, md, name, params)


def check_against_repeated_steps(fmu_dir, md, name: str, params: dict, quasi_step: float = 100.0):
    """Directional derivatives along random directions at random poses against Richardson
    differences of repeated steps (quasi-static: the step is quasi_step times larger)."""
    quasi = bool(params.get("model.quasi_static"))
    f = Fmu(fmu_dir, md, params)
    rng = random.Random(7)
    # quasi-static: a larger step keeps the load balance's TE floor (~1e-14 m) out of the differences
    step = STEP * (quasi_step if quasi else 1)
    checked = worst = 0
    time = 0.0
    try:
        for p in range(4):
            x0 = pose(rng, quasi)
            f.set(x0)
            f.s.doStep(time, H)  # warm start (quasi-static TE) at this pose
            time += H
            state = f.s.getFMUstate()  # before the step: repeated below with moved inputs
            t = time
            f.s.doStep(t, H)
            time = t + H
            after = f.s.getFMUstate()
            y0 = f.out()
            for _ in range(2):
                seed = {n: SCALE[kind(n)] * rng.uniform(-1, 1) for n in f.inputs}
                if not quasi:
                    seed["mesh.load_torque"] = 0.0
                f.s.setFMUstate(after)  # the published step (the differences below step again)
                d = f.s.getDirectionalDerivative(f.vr(f.outputs), f.vr(f.inputs), [seed[n] for n in f.inputs])

                def stepped(h):
                    f.s.setFMUstate(state)
                    f.set({n: x0.get(n, 0.0) + h * seed[n] for n in f.inputs})
                    f.s.doStep(t, H)
                    return f.out()

                yp, ym, yp2, ym2 = stepped(step), stepped(-step), stepped(step / 2), stepped(-step / 2)
                fd = [(4 * (a - b) / step - (c - e) / (2 * step)) / 3 for a, b, c, e in zip(yp2, ym2, yp, ym)]
                c1 = [(c - e) / (2 * step) for c, e in zip(yp, ym)]
                c2 = [(a - b) / step for a, b in zip(yp2, ym2)]
                scale = max(max(abs(v) for v in fd[:12]), 1e-300)
                # a pose where the finite differences are not converged (a slice touching) is skipped
                # (the central differences at h and h/2 must agree to a few 1e-5: Richardson's
                # extrapolation of them is then far more accurate than the tolerance)
                if any(abs(a - b) > 3e-5 * max(abs(b), 1e-3 * scale) + 1e-9 for a, b in zip(c1, c2)):
                    continue
                for n, a, b, y in zip(f.outputs, d, fd, y0):
                    allowed = 1e-5 * max(abs(a), abs(b)) + 1e-6 * max(abs(b), 1e-3 * abs(y)) + 1e-12
                    if n.startswith(("gear", "mesh.normal")):
                        allowed += 1e-6 * scale
                    if n == "mesh.max_load_share":  # (dF_max - share dF) / F: the forces' error / F
                        allowed += 2e-6 * scale / max(y0[f.outputs.index("mesh.normal_force")], 1e-300)
                    if quasi:  # the load balance's TE floor, ~1e-14 m, through the mesh stiffness
                        k = y0[f.outputs.index("mesh.stiffness")]
                        noise = {"mesh.stiffness": 1e-8 * abs(y), "mesh.max_line_load": 1e-14 * k / 4e-3,
                                 "mesh.te": 1e-14, "mesh.te_angle": 1e-12}.get(n, 1e-14 * k)
                        allowed += noise / step
                    worst = max(worst, abs(a - b) / allowed)
                    assert abs(a - b) <= allowed, f"{name}: d {n} = {a}, finite difference {b} (value {y})"
                checked += 1
            f.s.setFMUstate(after)
            # new inputs without a step: the derivative belongs to the outputs read there
            # (direct feedthrough), as after a step with those inputs held
            d_before = f.s.getDirectionalDerivative(f.vr(f.outputs), f.vr(["gear1.phi"]), [1e-3])
            f.set({"gear1.phi": x0["gear1.phi"] + 1e-3, "gear2.ux": 1e-6})
            d_after = f.s.getDirectionalDerivative(f.vr(f.outputs), f.vr(["gear1.phi"]), [1e-3])
            f.s.doStep(time, H)
            d_stepped = f.s.getDirectionalDerivative(f.vr(f.outputs), f.vr(["gear1.phi"]), [1e-3])
            assert d_after != d_before
            assert d_after == pytest.approx(d_stepped, rel=1e-9, abs=1e-9 * max(map(abs, d_stepped)))
            f.s.setFMUstate(after)
            f.s.freeFMUstate(state)
            f.s.freeFMUstate(after)
        print(f"{name}: {checked} directions checked, worst error/allowed {worst:.3g}")
        assert checked >= 5
    finally:
        f.free()


@pytest.mark.parametrize("quasi", [False, True], ids=["plain", "quasi-static"])
def test_axial_derivative_at_equal_face_ends_is_the_one_along_the_seed(fmu_dir, md, quasi):
    """At the default aligned pose (equal face widths, uz = 0) the axial overlap has a kink; the
    derivative along +-gear2.uz (and gear1.uz) is the one-sided difference of repeated steps along
    that direction, for every output (was 0 for gear1.mx, against 2356 N of every difference)."""
    # level 0, as written (the defaults are level 4): its mesh.stiffness does not depend on the
    # TE, so the quasi-static load balance's TE floor stays out of its differences, as the
    # allowance below (1e-14 |y| / h) assumes; at level 4 mesh.stiffness follows the solved TE and
    # its differences carry ~1e-9 relative noise (check_against_repeated_steps allows for that)
    params = {"solver.tolerance": 1e-15, "model.stiffness": 0, "model.slices": 3}
    if quasi:
        params["model.quasi_static"] = 1
    f = Fmu(fmu_dir, md, params)
    try:
        r_b2 = _rb2(f)
        x0 = {"gear1.phi": 0.01, "gear2.phi": -0.01 + 5e-6 / r_b2, "mesh.load_torque": 300.0 if quasi else 0.0}
        f.set(x0)
        f.s.doStep(0.0, H)
        f.s.doStep(H, H)  # quasi-static: the warm-started TE at its floor
        state = f.s.getFMUstate()
        f.s.doStep(2 * H, H)
        after = f.s.getFMUstate()
        y0 = f.out()
        h = 1e-6 if quasi else 1e-8  # quasi-static: the load balance's TE floor (~1e-14 m)
        for name in ("gear2.uz", "gear1.uz"):
            for direction in (1.0, -1.0):
                f.s.setFMUstate(after)
                d = f.s.getDirectionalDerivative(f.vr(f.outputs), f.vr([name]), [direction])

                def stepped(t):
                    f.s.setFMUstate(state)
                    f.set({name: direction * t})
                    f.s.doStep(2 * H, H)
                    return f.out()

                y1, y2 = stepped(h / 2), stepped(h)
                # second-order one-sided (Richardson) difference along the direction
                fd = [2 * (a - y) / (h / 2) - (b - y) / h for a, b, y in zip(y1, y2, y0)]
                scale = max(abs(v) for v in fd[:12])
                assert abs(d[f.outputs.index("gear1.mx")]) > 1e-3 * scale
                for n, a, b, y in zip(f.outputs, d, fd, y0):
                    allowed = (1e-4 if quasi else 1e-6) * scale + 1e-14 * abs(y) / h + 1e-9
                    assert abs(a - b) <= allowed, f"d {n}/d {name} along {direction}: {a}, difference {b}"
        f.s.setFMUstate(after)
        f.s.freeFMUstate(state)
        f.s.freeFMUstate(after)
    finally:
        f.free()


def test_parameter_as_known_is_refused(fmu_dir, md, capfd):
    f = Fmu(fmu_dir, md, {})
    try:
        f.set({"gear1.phi": 1e-4, "gear1.omega": W, "gear2.omega": -W})
        f.s.doStep(0.0, H)
        with pytest.raises(FMICallException):
            f.s.getDirectionalDerivative(f.vr(["gear1.fx"]), f.vr(["pair.center_distance"]), [1.0])
        assert "known pair.center_distance" in capfd.readouterr().out  # fmpy's logger prints it
        with pytest.raises(FMICallException):  # unknowns must be Real outputs
            f.s.getDirectionalDerivative(f.vr(["gear1.phi"]), f.vr(["gear1.phi"]), [1.0])
        # still usable afterwards: a refused call does not change the instance
        d = f.s.getDirectionalDerivative(f.vr(["mesh.te"]), f.vr(["gear2.phi"]), [1.0])
        assert d[0] == pytest.approx(_rb2(f), rel=1e-12)
        f.s.doStep(H, H)
    finally:
        f.free()


def _rb2(f: Fmu) -> float:
    """te = r_b1 phi1 + r_b2 phi2 for the external pair: d te/d phi2 = r_b2."""
    return 0.5 * f.s.getReal(f.vr(["gear2.base_diameter"]))[0]
