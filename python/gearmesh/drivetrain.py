"""The reference drivetrain, and the two masters that couple a mechanical model (a plant) to the
FMU with legal FMI 2.0 calls only.

    speed-controlled motor (PI, inertia J_m) -- input shaft (k1, c1) -- gear 1 (J1)
        == GearMesh ==  gear 2 (J2) -- output shaft (k2, c2) -- load (J_L) + brake torque T_b

Torsional: the mesh connects gear<i>.phi and gear<i>.omega and returns gear<i>.mz (moments on
the gears about +z). The brake torque T_b on the load resists the flank-A drive (gear 2 turns
in -phi for an external pair, so the brake acts in +z on the load).

Masters (Integrator; a plant gives rhs, its Jacobian, the links to the FMU inputs and the energy
flows):

* implicit (stiff-stable): the trapezoidal rule over the whole state, x1 = x0 + h/2 (f(x0) +
  f(x1)), solved by Newton. The mesh moments at x1 come from the FMU: fmi2GetFMUstate before the
  step, set the end-of-step inputs, fmi2DoStep(t, h), read the moments; for the next Newton
  iteration fmi2SetFMUstate and repeat the step with the corrected inputs. The Newton matrix
  needs d(mz)/d(phi, omega): from fmi2GetDirectionalDerivative when the FMU provides it, else
  from finite differences of repeated steps (also only legal calls). A-stable; limited by
  accuracy (h well below the mesh period 2 pi/(z1 omega_1) to resolve the mesh orders, and the
  friction reversal at the pitch point, which the rule smears over a step).
* explicit: symplectic (semi-implicit) Euler, one fmi2DoStep per step: the speeds first from
  the forces at the start of the step (the mesh outputs of the last step), then the angles from
  the new speeds; the FMU then evaluates the end-of-step pose. On an undamped mesh oscillator it
  is stable for h < 2/omega_mesh (omega_mesh = sqrt(k_mesh (r_b1^2/J1 + r_b2^2/J2))); the
  mesh's stiffness varies over the mesh cycle and jumps at contact, so the measured limit is
  about half of that (docs/stability.md, `gearmesh stability`). Mesh damping and shaft damping
  enter explicitly: the step must also stay below about 2 J_eq/c of every damper.
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field

import numpy as np

from gearmesh.fmu_driver import FMUError, GearMeshFMU

PHI = ["gear1.phi", "gear2.phi"]
OMEGA = ["gear1.omega", "gear2.omega"]
MOMENTS = ["gear1.mz", "gear2.mz"]
# Mesh outputs the masters record each step (besides the ones that act on the plant).
RECORDED = ["mesh.te", "mesh.normal_force", "mesh.friction_power", "mesh.stiffness"]


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
    x: np.ndarray                     # states per time (see the plant's state list)
    mesh: dict                        # output name -> array (one row per step, at t[1:])
    energy: dict = field(default_factory=dict)
    fmu_calls: int = 0
    retries: int = 0                  # implicit: Newton failures recovered by halving the step
    mesh0: dict = field(default_factory=dict)  # the outputs at the start state


STATE = ["phi_m", "omega_m", "integral", "phi1", "omega1", "phi2", "omega2", "phi_L", "omega_L"]
# With bearings, each gear centre adds (ux, uy, vx, vy) after these.
LATERAL = ["ux", "uy", "vx", "vy"]


def pair_ratio(fmu: GearMeshFMU) -> float:
    """omega2 / omega1 of conjugate motion."""
    g = fmu.get(["gear1.base_diameter", "gear2.base_diameter", "pair.internal"])
    return -(g["gear1.base_diameter"] / g["gear2.base_diameter"]) * (
        -1 if g["pair.internal"] else 1)


class DrivetrainPlant:
    """The reference drivetrain as a plant of the masters. links: (state index, FMU input)
    pairs that the mesh sees; outputs: the mesh outputs that act back on the state."""

    def __init__(self, fmu: GearMeshFMU, p: Drivetrain):
        self.p = p
        self.ratio = pair_ratio(fmu)
        self.bearings = p.bearing_stiffness > 0
        self.links = [(3, "gear1.phi"), (4, "gear1.omega"), (5, "gear2.phi"), (6, "gear2.omega")]
        self.outputs = list(MOMENTS)
        if self.bearings:
            for gear in (1, 2):
                base = len(STATE) + 4 * (gear - 1)
                self.links += [(base + k, f"gear{gear}.{name}") for k, name in enumerate(LATERAL)]
                self.outputs += [f"gear{gear}.fx", f"gear{gear}.fy"]
        self.size = len(STATE) + (8 if self.bearings else 0)
        self.recorded: list[str] = []
        self.x0 = np.zeros(self.size)
        self.velocity_rows = [1, 4, 6, 8] + ([11, 12, 15, 16] if self.bearings else [])
        self.scale = np.array([1e-3, 1e-2, 1e-3, 1e-6, 1e-3, 1e-6, 1e-3, 1e-3, 1e-2]
                              + [1e-9, 1e-9, 1e-6, 1e-6] * (2 if self.bearings else 0))

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

    def powers(self, t: float, x: np.ndarray, out: dict) -> dict:
        """Energy flows at a state (W): the sources' work rates and the losses."""
        p = self.p
        m = np.array([out[name] for name in self.outputs])
        e = self.omega_ref(t) - x[1]
        T_m = p.kp * e + p.ki * x[2]
        damp = p.c1 * (x[1] - x[4]) ** 2 + p.c2 * (x[8] - x[6]) ** 2
        mesh_in = -(m[0] * x[4] + m[1] * x[6])
        if self.bearings:
            v = x[[11, 12, 15, 16]]
            damp += p.bearing_damping * float(v @ v)
            mesh_in -= float(m[2:6] @ v)  # the mesh forces' power on the moving centres
        return {"motor": T_m * x[1], "brake": p.brake_torque * self._brake_sign() * x[8],
                "damping": damp, "mesh_in": mesh_in, "friction": out["mesh.friction_power"]}

    def stored(self, X: np.ndarray) -> np.ndarray:
        """Kinetic + spring energy per state row."""
        p = self.p
        kinetic = 0.5 * (p.J_motor * X[:, 1] ** 2 + p.J1 * X[:, 4] ** 2 + p.J2 * X[:, 6] ** 2
                         + p.J_load * X[:, 8] ** 2)
        springs = 0.5 * (p.k1 * (X[:, 0] - X[:, 3]) ** 2 + p.k2 * (X[:, 7] - X[:, 5]) ** 2)
        if self.bearings:
            kinetic = kinetic + 0.5 * p.gear_mass * np.sum(X[:, [11, 12, 15, 16]] ** 2, axis=1)
            springs = springs + 0.5 * p.bearing_stiffness * np.sum(X[:, [9, 10, 13, 14]] ** 2,
                                                                   axis=1)
        return kinetic + springs

    def balance(self, energy: dict, T: np.ndarray, X: np.ndarray, mesh0: dict,
                mesh_end: dict) -> dict:
        """motor work + brake work = stored + dissipated in the dampers + absorbed by the mesh."""
        stored = self.stored(X[[0, -1]])
        energy["stored"] = stored[1] - stored[0]
        energy["residual"] = energy["motor"] + energy["brake"] - energy["stored"] \
            - energy["damping"] - energy["mesh_in"]
        return energy

    def jacobian(self, t: float, x: np.ndarray, Jm: np.ndarray) -> np.ndarray:
        """d(rhs)/dx with the mesh Jacobian Jm = d(outputs)/d(linked states)."""
        p = self.p
        A = np.zeros((self.size, self.size))
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
        # rows that the mesh outputs drive, in the order of self.outputs, and their inertias
        rows = [(4, p.J1), (6, p.J2)]
        if self.bearings:
            for gear in range(2):
                b = 9 + 4 * gear
                A[b, b + 2] = A[b + 1, b + 3] = 1
                for k in (0, 1):
                    A[b + 2 + k, b + k] = -p.bearing_stiffness / p.gear_mass
                    A[b + 2 + k, b + 2 + k] = -p.bearing_damping / p.gear_mass
                rows += [(b + 2, p.gear_mass), (b + 3, p.gear_mass)]
        columns = [i for i, _ in self.links]
        for (row, inertia), jac in zip(rows, Jm):
            A[row, columns] += jac / inertia
        return A


class Coupling:
    """The FMU side of a master: set the linked states as inputs, step, read the outputs."""

    def __init__(self, fmu: GearMeshFMU, plant):
        self.fmu, self.plant = fmu, plant
        self.directional = bool(fmu.model_description.coSimulation.providesDirectionalDerivative)
        self.calls = 0
        # the plant's optional outputs are read where the FMU has them (older builds lack some)
        optional = [n for n in RECORDED + list(plant.recorded) if n in fmu.variables]
        self.read = list(dict.fromkeys(plant.outputs + optional))

    def mesh_step(self, t: float, h: float, x: np.ndarray) -> dict:
        """Mesh outputs at t + h for the states of x, as one FMI step."""
        self.fmu.set({name: x[i] for i, name in self.plant.links})
        self.fmu._call(self.fmu.fmu.doStep, currentCommunicationPoint=t, communicationStepSize=h)
        self.calls += 1
        return self.fmu.get(self.read)

    def mesh_jacobian(self, t: float, h: float, x: np.ndarray, base: dict, state) -> np.ndarray:
        """d(outputs)/d(linked states) at the end-of-step inputs of x."""
        links, outputs = self.plant.links, self.plant.outputs
        J = np.zeros((len(outputs), len(links)))
        if self.directional:
            refs = [self.fmu.variables[n].valueReference for n in outputs]
            for j, (_, name) in enumerate(links):
                J[:, j] = self.fmu.fmu.getDirectionalDerivative(
                    refs, [self.fmu.variables[name].valueReference], [1.0])
            return J
        for j, (i, name) in enumerate(links):
            dx = 1e-8 if name.endswith(("phi", ".ux", ".uy")) else 1e-6
            xp = x.copy()
            xp[i] += dx
            self.fmu.fmu.setFMUstate(state)
            out = self.mesh_step(t, h, xp)
            J[:, j] = [(out[m] - base[m]) / dx for m in outputs]
        return J


class Integrator:
    """One master run, step by step: advance(t_end) integrates from where it stands; snapshot()
    and restore() save and roll back the master's and the FMU's state together (fmi2GetFMUstate
    / fmi2SetFMUstate). The first call evaluates the start state with one fmi2DoStep of h."""

    def __init__(self, fmu: GearMeshFMU, plant, h: float, implicit: bool = True,
                 newton_tol: float = 1e-10, max_newton: int = 8, h_min: float = 1e-7):
        self.fmu, self.plant, self.h, self.implicit = fmu, plant, h, implicit
        self.newton_tol, self.max_newton, self.h_min = newton_tol, max_newton, h_min
        self.c = Coupling(fmu, plant)
        self.x = plant.x0.copy()
        self.t = 0.0
        self.out0 = self.c.mesh_step(fmu.time, h, self.x)  # outputs of the start inputs
        fmu.time += h
        self.t_fmu = fmu.time                               # the FMU's communication point
        self.mesh0 = dict(self.out0)
        self.m0 = self._moments(self.out0)
        self.energy: dict[str, float] = {}
        self.times, self.states, self.rows = [0.0], [self.x.copy()], {}
        self.retries = 0
        self.step = h
        vel = np.zeros(plant.size, bool)
        vel[plant.velocity_rows] = True
        self.vel, self.pos = vel, ~vel

    def _moments(self, out: dict) -> np.ndarray:
        return np.array([out[m] for m in self.plant.outputs])

    def advance(self, t_end: float, step_sizes=None) -> None:
        """Integrate to t_end. step_sizes: an iterator of communication steps (default: h,
        grown back to h after an implicit halving)."""
        while self.t < t_end - 1e-12:
            want = next(step_sizes) if step_sizes is not None else self.step
            self._one(min(want, t_end - self.t))

    def _one(self, step: float) -> None:
        plant, c, x, t = self.plant, self.c, self.x, self.t
        f0 = plant.rhs(t, x, self.m0)
        if not self.implicit:
            x1 = x.copy()
            x1[self.vel] = x[self.vel] + step * f0[self.vel]        # speeds from the start forces
            f_new = plant.rhs(t + step, x1, self.m0)
            x1[self.pos] = x[self.pos] + step * f_new[self.pos]     # angles from the new speeds
            out = c.mesh_step(self.t_fmu, step, x1)
        else:
            while True:
                x1, out = self._newton(t, step, x, f0)
                if x1 is not None:
                    break
                self.retries += 1
                if step / 2 < self.h_min:
                    raise RuntimeError(f"t = {t:.6g} s: Newton did not converge down to a step "
                                       f"of {self.h_min:g} s")
                step /= 2
        m1 = self._moments(out)
        p0, p1 = plant.powers(t, x, self.out0), plant.powers(t + step, x1, out)
        for key in p0:
            self.energy[key] = self.energy.get(key, 0.0) + 0.5 * step * (p0[key] + p1[key])
        self.x, self.m0, self.out0 = x1, m1, out
        self.t += step
        self.t_fmu += step
        self.times.append(self.t)
        self.states.append(x1.copy())
        for k, v in out.items():
            self.rows.setdefault(k, []).append(v)
        self.step = min(self.h, 2 * step)

    def _newton(self, t, step, x, f0):
        """The trapezoidal step by Newton; (None, None) if it does not converge."""
        plant, c = self.plant, self.c
        state = self.fmu.fmu.getFMUstate()
        try:
            x1 = x + step * f0  # predictor
            for _ in range(self.max_newton):
                self.fmu.fmu.setFMUstate(state)
                try:
                    out = c.mesh_step(self.t_fmu, step, x1)
                except FMUError as exc:  # an iterate that skips a tooth: a smaller step
                    if not exc.discarded:
                        raise
                    break
                residual = x1 - x - 0.5 * step * (f0 + plant.rhs(t + step, x1, self._moments(out)))
                if np.max(np.abs(residual) / plant.scale) < self.newton_tol * 1e6:
                    self.fmu.fmu.setFMUstate(state)
                    return x1, c.mesh_step(self.t_fmu, step, x1)
                Jm = c.mesh_jacobian(self.t_fmu, step, x1, out, state)
                A = np.eye(plant.size) - 0.5 * step * plant.jacobian(t + step, x1, Jm)
                x1 = x1 - np.linalg.solve(A, residual)
            self.fmu.fmu.setFMUstate(state)
            return None, None
        finally:
            self.fmu.fmu.freeFMUstate(state)

    _SAVED = ("x", "t", "t_fmu", "m0", "out0", "energy", "times", "states", "rows", "retries",
              "step")

    def snapshot(self) -> dict:
        """The master's state and the FMU's (free it with forget())."""
        saved = {k: copy.deepcopy(getattr(self, k)) for k in self._SAVED}
        saved["fmu_state"] = self.fmu.fmu.getFMUstate()
        saved["fmu_time"] = self.fmu.time
        return saved

    def restore(self, saved: dict) -> None:
        for k in self._SAVED:
            setattr(self, k, copy.deepcopy(saved[k]))
        self.fmu.fmu.setFMUstate(saved["fmu_state"])
        self.fmu.time = saved["fmu_time"]

    def forget(self, saved: dict) -> None:
        self.fmu.fmu.freeFMUstate(saved["fmu_state"])

    def result(self) -> Result:
        self.fmu.time = self.t_fmu
        X = np.array(self.states)
        mesh = {k: np.asarray(v) for k, v in self.rows.items()}
        last = {k: v[-1] for k, v in self.rows.items()} if self.rows else self.mesh0
        T = np.array(self.times)
        energy = self.plant.balance(dict(self.energy), T, X, self.mesh0, last)
        return Result(T, X, mesh, energy, self.c.calls, self.retries,
                      self.mesh0)


def integrate(fmu: GearMeshFMU, plant, t_end: float, h: float, implicit: bool = True,
              **options) -> Result:
    """Run a plant coupled to the FMU from its start state to t_end with steps of h."""
    run = Integrator(fmu, plant, h, implicit, **options)
    run.advance(t_end)
    return run.result()


def simulate(fmu: GearMeshFMU, p: Drivetrain, t_end: float, h: float, implicit: bool = True,
             newton_tol: float = 1e-10, max_newton: int = 8, h_min: float = 1e-7) -> Result:
    """Integrate the reference drivetrain from rest (gears in contact at TE = 0) to t_end with
    steps of h. The implicit scheme halves a step whose Newton iteration does not converge
    (friction reversals, flank changes) or whose iterate the FMU discards (a TE jump of a
    skipped tooth) and grows back to h after a success; the explicit (symplectic Euler) master
    keeps h."""
    return integrate(fmu, DrivetrainPlant(fmu, p), t_end, h, implicit, newton_tol=newton_tol,
                     max_newton=max_newton, h_min=h_min)
