"""The reference drivetrain, driven through fmpy with legal FMI 2.0 calls only.

    speed-controlled motor (PI, inertia J_m) -- input shaft (k1, c1) -- gear 1 (J1)
        == GearMesh ==  gear 2 (J2) -- output shaft (k2, c2) -- load (J_L) + brake torque T_b

Torsional: the mesh connects gear<i>.phi and gear<i>.omega and returns gear<i>.mz (moments on
the gears about +z). The brake torque T_b on the load resists the flank-A drive (gear 2 turns
in -phi for an external pair, so the brake acts in +z on the load).

Scheme (stiff-stable, implicit trapezoidal rule over the whole state): each step solves
    x1 = x0 + h/2 (f(x0) + f(x1))
by Newton. The mesh moments at x1 come from the FMU: fmi2GetFMUstate before the step, set the
end-of-step inputs, fmi2DoStep(t, h) (outputs published for t + h from the inputs held over the
step), read the moments; for the next Newton iteration fmi2SetFMUstate and repeat the step with
the corrected inputs. The Newton matrix needs d(mz)/d(phi, omega): from fmi2GetDirectionalDerivative
when the FMU provides it, else from finite differences by repeating the step with perturbed
inputs (also only legal calls). Explicit coupling (the FMU evaluated once per step at the start
inputs, forward Euler) is there for comparison: it is limited to h < 2/omega_mesh, where
omega_mesh = sqrt(k_mesh (r_b1^2/J1 + r_b2^2/J2)), while the trapezoidal rule is A-stable and
limited only by accuracy (h well below the mesh period 2 pi/(z1 omega_1) to resolve the mesh
orders).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gearmesh.fmu_driver import FMUError, GearMeshFMU

PHI = ["gear1.phi", "gear2.phi"]
OMEGA = ["gear1.omega", "gear2.omega"]
MOMENTS = ["gear1.mz", "gear2.mz"]


@dataclass
class Drivetrain:
    """Parameters, SI. Defaults: the paper's test rig at 10 rpm, roughly."""
    speed_rpm: float = 10.0           # motor speed set point
    brake_torque: float = 200.0       # N m on the load, resisting the flank-A drive
    J_motor: float = 0.05             # kg m^2
    J1: float = 0.02                  # gear 1 (with its hub), kg m^2
    J2: float = 0.02
    J_load: float = 0.5
    k1: float = 2.0e4                 # input shaft, N m/rad
    c1: float = 100.0                 # N m s/rad
    k2: float = 2.0e4                 # output shaft
    c2: float = 100.0
    kp: float = 50.0                  # speed controller, N m s/rad
    ki: float = 500.0                 # N m/rad
    spin_up: float = 0.2              # s, ramp of the set point
    bearing_stiffness: float = 0.0    # N/m on each gear centre in x and y; 0 = rigid bearings
    bearing_damping: float = 0.0      # N s/m
    gear_mass: float = 2.0            # kg, each gear (used with bearings)


@dataclass
class Result:
    t: np.ndarray
    x: np.ndarray                     # states per time (see STATE)
    mesh: dict                        # output name -> array
    energy: dict = field(default_factory=dict)
    fmu_calls: int = 0


STATE = ["phi_m", "omega_m", "integral", "phi1", "omega1", "phi2", "omega2", "phi_L", "omega_L"]
# With bearings, each gear centre adds (ux, uy, vx, vy) after these.
LATERAL = ["ux", "uy", "vx", "vy"]


class Coupled:
    """The mechanical model around one FMU instance. links: (state index, FMU input) pairs that
    the mesh sees; outputs: the mesh outputs that act back on the state."""

    def __init__(self, fmu: GearMeshFMU, p: Drivetrain):
        self.fmu, self.p = fmu, p
        g = fmu.get(["gear1.base_diameter", "gear2.base_diameter", "pair.internal"])
        self.ratio = -(g["gear1.base_diameter"] / g["gear2.base_diameter"]) * (
            -1 if g["pair.internal"] else 1)  # omega2 / omega1 of conjugate motion
        self.directional = bool(fmu.model_description.coSimulation.providesDirectionalDerivative)
        self.calls = 0
        self.bearings = p.bearing_stiffness > 0
        self.links = [(3, "gear1.phi"), (4, "gear1.omega"), (5, "gear2.phi"), (6, "gear2.omega")]
        self.outputs = list(MOMENTS)
        if self.bearings:
            for gear in (1, 2):
                base = len(STATE) + 4 * (gear - 1)
                self.links += [(base + k, f"gear{gear}.{name}") for k, name in enumerate(LATERAL)]
                self.outputs += [f"gear{gear}.fx", f"gear{gear}.fy"]
        self.size = len(STATE) + (8 if self.bearings else 0)

    def omega_ref(self, t: float) -> float:
        w = self.p.speed_rpm * 2 * math.pi / 60
        return w * min(1.0, t / self.p.spin_up) if self.p.spin_up > 0 else w

    def rhs(self, t: float, x: np.ndarray, m: np.ndarray) -> np.ndarray:
        """dx/dt for the mesh outputs m (in the order of self.outputs)."""
        p = self.p
        phi_m, w_m, integ, phi1, w1, phi2, w2, phi_L, w_L = x[:9]
        e = self.omega_ref(t) - w_m
        T_m = p.kp * e + p.ki * integ
        shaft1 = p.k1 * (phi_m - phi1) + p.c1 * (w_m - w1)
        shaft2 = p.k2 * (phi_L - phi2) + p.c2 * (w_L - w2)
        dx = [w_m, (T_m - shaft1) / p.J_motor, e,
              w1, (shaft1 + m[0]) / p.J1,
              w2, (shaft2 + m[1]) / p.J2,
              w_L, (-shaft2 + p.brake_torque * self._brake_sign()) / p.J_load]
        if self.bearings:
            for gear in range(2):
                ux, uy, vx, vy = x[9 + 4 * gear: 13 + 4 * gear]
                fx, fy = m[2 + 2 * gear], m[3 + 2 * gear]
                k, c, mass = p.bearing_stiffness, p.bearing_damping, p.gear_mass
                dx += [vx, vy, (fx - k * ux - c * vx) / mass, (fy - k * uy - c * vy) / mass]
        return np.array(dx)

    def _brake_sign(self) -> float:
        return 1.0 if self.ratio < 0 else -1.0  # against gear 2's rotation under flank-A drive

    def mesh_step(self, t: float, h: float, x: np.ndarray) -> dict:
        """Mesh outputs at t + h for the gear states of x, as one FMI step."""
        self.fmu.set({name: x[i] for i, name in self.links})
        self.fmu._call(self.fmu.fmu.doStep, currentCommunicationPoint=t, communicationStepSize=h)
        self.calls += 1
        return self.fmu.get(self.outputs + ["mesh.te", "mesh.normal_force",
                                            "mesh.friction_power", "mesh.stiffness"])

    def mesh_jacobian(self, t: float, h: float, x: np.ndarray, base: dict, state) -> np.ndarray:
        """d(outputs)/d(linked states) at the end-of-step inputs of x."""
        J = np.zeros((len(self.outputs), len(self.links)))
        if self.directional:
            refs = [self.fmu.variables[n].valueReference for n in self.outputs]
            for j, (_, name) in enumerate(self.links):
                J[:, j] = self.fmu.fmu.getDirectionalDerivative(
                    refs, [self.fmu.variables[name].valueReference], [1.0])
            return J
        for j, (i, name) in enumerate(self.links):
            dx = 1e-8 if name.endswith(("phi", ".ux", ".uy")) else 1e-6
            xp = x.copy()
            xp[i] += dx
            self.fmu.fmu.setFMUstate(state)
            out = self.mesh_step(t, h, xp)
            J[:, j] = [(out[m] - base[m]) / dx for m in self.outputs]
        return J


def simulate(fmu: GearMeshFMU, p: Drivetrain, t_end: float, h: float, implicit: bool = True,
             newton_tol: float = 1e-10, max_newton: int = 8, h_min: float = 1e-7) -> Result:
    """Integrate from rest (gears in contact at TE = 0) to t_end with steps of h. The implicit
    scheme halves a step whose Newton iteration does not converge (friction reversals, flank
    changes) or whose iterate the FMU discards (a TE jump of a skipped tooth) and grows back to
    h after a success; explicit coupling keeps h."""
    c = Coupled(fmu, p)
    x = np.zeros(c.size)
    times, states = [0.0], [x.copy()]
    mesh_rows: dict[str, list] = {}
    t = 0.0
    out0 = c.mesh_step(fmu.time, h, x)  # outputs of the start inputs
    fmu.time += h
    t_fmu = fmu.time                     # the FMU's communication point
    m0 = np.array([out0[m] for m in c.outputs])
    energy = {"motor": 0.0, "brake": 0.0, "damping": 0.0, "mesh_in": 0.0, "friction": 0.0}
    scale = np.array([1e-3, 1e-2, 1e-3, 1e-6, 1e-3, 1e-6, 1e-3, 1e-3, 1e-2]
                     + [1e-9, 1e-9, 1e-6, 1e-6] * (2 if c.bearings else 0))  # state units

    def powers(tt, xx, mm):
        e = c.omega_ref(tt) - xx[1]
        T_m = p.kp * e + p.ki * xx[2]
        damp = p.c1 * (xx[1] - xx[4]) ** 2 + p.c2 * (xx[8] - xx[6]) ** 2
        mesh_in = -(mm[0] * xx[4] + mm[1] * xx[6])
        if c.bearings:
            v = xx[[11, 12, 15, 16]]
            damp += p.bearing_damping * float(v @ v)
            mesh_in -= float(mm[2:6] @ v)  # the mesh forces' power on the moving centres
        return np.array([T_m * xx[1], p.brake_torque * c._brake_sign() * xx[8], damp, mesh_in])

    step = h
    while t < t_end - 1e-12:
        step = min(step, t_end - t)
        f0 = c.rhs(t, x, m0)
        if not implicit:
            x1 = x + step * f0
            out = c.mesh_step(t_fmu, step, x1)
        else:
            state = fmu.fmu.getFMUstate()
            x1 = x + step * f0  # predictor
            converged = False
            for it in range(max_newton):
                fmu.fmu.setFMUstate(state)
                try:
                    out = c.mesh_step(t_fmu, step, x1)
                except FMUError as exc:  # an iterate that skips a tooth: a smaller step
                    if not exc.discarded:
                        raise
                    break
                m1 = np.array([out[m] for m in c.outputs])
                residual = x1 - x - 0.5 * step * (f0 + c.rhs(t + step, x1, m1))
                if np.max(np.abs(residual) / scale) < newton_tol * 1e6:
                    converged = True
                    break
                Jm = c.mesh_jacobian(t_fmu, step, x1, out, state)
                A = np.eye(c.size) - 0.5 * step * _rhs_jacobian(c, t + step, x1, Jm)
                x1 = x1 - np.linalg.solve(A, residual)
            fmu.fmu.setFMUstate(state)
            if not converged:
                fmu.fmu.freeFMUstate(state)
                if step / 2 < h_min:
                    raise RuntimeError(f"t = {t:.6g} s: Newton did not converge down to a step "
                                       f"of {h_min:g} s")
                step /= 2
                continue
            out = c.mesh_step(t_fmu, step, x1)
            fmu.fmu.freeFMUstate(state)
        m1 = np.array([out[m] for m in c.outputs])
        pw = 0.5 * step * (powers(t, x, m0) + powers(t + step, x1, m1))
        for key, v in zip(("motor", "brake", "damping", "mesh_in"), pw):
            energy[key] += v
        energy["friction"] += step * out["mesh.friction_power"]
        x, m0 = x1, m1
        t += step
        t_fmu += step
        times.append(t)
        states.append(x.copy())
        for k, v in out.items():
            mesh_rows.setdefault(k, []).append(v)
        step = min(h, 2 * step)
    fmu.time = t_fmu
    X = np.array(states)
    kinetic = 0.5 * (p.J_motor * X[:, 1] ** 2 + p.J1 * X[:, 4] ** 2 + p.J2 * X[:, 6] ** 2
                     + p.J_load * X[:, 8] ** 2)
    springs = 0.5 * (p.k1 * (X[:, 0] - X[:, 3]) ** 2 + p.k2 * (X[:, 7] - X[:, 5]) ** 2)
    if c.bearings:
        kinetic = kinetic + 0.5 * p.gear_mass * np.sum(X[:, [11, 12, 15, 16]] ** 2, axis=1)
        springs = springs + 0.5 * p.bearing_stiffness * np.sum(X[:, [9, 10, 13, 14]] ** 2, axis=1)
    stored = kinetic[-1] - kinetic[0] + springs[-1] - springs[0]
    # motor work + brake work = stored + dissipated in the dampers + absorbed by the mesh
    energy["stored"] = stored
    energy["residual"] = energy["motor"] + energy["brake"] - stored - energy["damping"] \
        - energy["mesh_in"]
    return Result(np.array(times), X, {k: np.asarray(v) for k, v in mesh_rows.items()},
                  energy, c.calls)


def _rhs_jacobian(c: Coupled, t: float, x: np.ndarray, Jm: np.ndarray) -> np.ndarray:
    """d(rhs)/dx with the mesh Jacobian Jm = d(outputs)/d(linked states)."""
    p = c.p
    A = np.zeros((c.size, c.size))
    A[0, 1] = 1
    A[1, 1] = (-p.kp - p.c1) / p.J_motor
    A[1, 2] = p.ki / p.J_motor
    A[1, 0] = -p.k1 / p.J_motor
    A[1, 3] = p.k1 / p.J_motor
    A[1, 4] = p.c1 / p.J_motor
    A[2, 1] = -1
    A[3, 4] = 1
    A[4, 0] = p.k1 / p.J1
    A[4, 1] = p.c1 / p.J1
    A[4, 3] = -p.k1 / p.J1
    A[4, 4] = -p.c1 / p.J1
    A[5, 6] = 1
    A[6, 7] = p.k2 / p.J2
    A[6, 8] = p.c2 / p.J2
    A[6, 5] = -p.k2 / p.J2
    A[6, 6] = -p.c2 / p.J2
    A[7, 8] = 1
    A[8, 7] = -p.k2 / p.J_load
    A[8, 8] = -p.c2 / p.J_load
    A[8, 5] = p.k2 / p.J_load
    A[8, 6] = p.c2 / p.J_load
    # rows that the mesh outputs drive, in the order of c.outputs, and their inertias
    rows = [(4, p.J1), (6, p.J2)]
    if c.bearings:
        for gear in range(2):
            b = 9 + 4 * gear
            A[b, b + 2] = A[b + 1, b + 3] = 1
            for k in (0, 1):
                A[b + 2 + k, b + k] = -p.bearing_stiffness / p.gear_mass
                A[b + 2 + k, b + 2 + k] = -p.bearing_damping / p.gear_mass
            rows += [(b + 2, p.gear_mass), (b + 3, p.gear_mass)]
    columns = [i for i, _ in c.links]
    for (row, inertia), jac in zip(rows, Jm):
        A[row, columns] += jac / inertia
    return A
