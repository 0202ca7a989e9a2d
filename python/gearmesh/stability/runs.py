"""One run of a stability case (gearmesh.stability.cases) in one mode at one communication step,
and what the judgement needs from it: the outputs over time, errors, the energy balance, the
quasi-static TE at the same gear-1 angles.

Modes:
* explicit         the plain element (model.dynamics 0) under gearmesh.drivetrain's explicit
                   master (symplectic Euler, one fmi2DoStep per step);
* implicit         the plain element under its implicit master (trapezoidal rule, Newton over
                   repeated steps with fmi2GetFMUstate/fmi2SetFMUstate);
* large_step       the large-step mode (model.dynamics 1: the FMU integrates the gear spins),
                   one fmi2DoStep per communication step through fmpy's simulate_fmu with the
                   torques and the shaft far ends as input signals;
* large_step_chain the large-step mode in a chain: the driving machine (motor inertia 2 kg m^2
                   under a PI speed controller) and the load inertia (2 kg m^2, carrying the
                   load torque) are a Python model coupled explicitly through the shafts
                   (gear<i>.shaft_phi/_omega in, gear<i>.shaft_torque out; symplectic Euler
                   on the Python side with the shaft torques of the last step).
"""
from __future__ import annotations

import dataclasses
import math
import pathlib
import time
from dataclasses import dataclass, field

import numpy as np

from fmpy.fmi1 import FMICallException

from gearmesh.drivetrain import Drivetrain, DrivetrainPlant, Integrator
from gearmesh.fmu_driver import FMUError, GearMeshFMU, _unpacked
from gearmesh.gear_pair import GearPair, GearPairPlant, Shaft
from gearmesh.stability.cases import SHAFT_C, SHAFT_K, Case, Geometry, driven_pair

MODES = ["explicit", "implicit", "large_step", "large_step_chain"]
CHAIN_J, CHAIN_KP, CHAIN_KI = 2.0, 50.0, 500.0
REFERENCE_STEP = 5e-6   # s: the converged dynamics (implicit master), every case's TE reference
LARGE_STEP = {"dynamics.tolerance": 1e-9, "dynamics.max_step": 1e-3, "dynamics.min_step": 1e-12}


@dataclass
class Prepared:
    """A case made concrete for one FMU: parameters, held inputs, the gear pair."""
    case: Case
    fmu_path: pathlib.Path
    params: dict
    inputs: dict
    geo: Geometry
    load: float
    pair: GearPair
    converged: dict = field(default_factory=dict)  # plant -> (t, TE) of the converged dynamics


@dataclass
class Run:
    case: str
    mode: str
    step: float
    error: str = ""                   # an FMI error, a discarded step, a failed master
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    te: np.ndarray = field(default_factory=lambda: np.zeros(0))
    phi1: np.ndarray = field(default_factory=lambda: np.zeros(0))
    omega: tuple = ()                 # (gear-1 speeds, gear-2 speeds) at the samples
    force: np.ndarray = field(default_factory=lambda: np.zeros(0))
    flank: np.ndarray = field(default_factory=lambda: np.zeros(0))
    residual: float = math.nan        # J
    work_in: float = math.nan         # J: initial energy + positive work of each source
    unconverged: int = 0              # force solves or master/FMU integrations that failed
    retries: int = 0                  # implicit master: Newton failures recovered by halving
    nan_count: int = 0
    steps: int = 0                    # communication steps taken
    seconds: float = 0.0              # wall time of the run
    internal_steps: int = 0           # large-step mode: the FMU's internal steps, summed
    rejected: int = 0
    rollback_gap: float = math.nan    # rollback case: largest difference of the continuations
    largest_energy: float = math.nan  # large-step mode: the largest kinetic + elastic energy, J
    te_ref: np.ndarray | None = None  # the reference TE at the samples (te_check cases)
    te_cut: np.ndarray | None = None  # large_step_chain: the converged chain's TE (no cut)


def _value(v, geo):
    return v(geo) if callable(v) else v


def geometry(fmu_path: pathlib.Path, params: dict) -> Geometry:
    with GearMeshFMU(fmu_path, params) as f:
        g = f.get(["gear1.base_diameter", "gear2.base_diameter", "pair.internal",
                   "geometry.backlash", "geometry.base_pitch", "geometry.tight_center_distance",
                   "pair.center_distance", "gear1.face_width", "gear2.face_width",
                   "model.user_stiffness"])
    face = min(g["gear1.face_width"], g["gear2.face_width"])
    return Geometry(g["gear1.base_diameter"] / 2, g["gear2.base_diameter"] / 2,
                    -1 if g["pair.internal"] else 1, g["geometry.backlash"],
                    g["geometry.base_pitch"], g["geometry.tight_center_distance"],
                    g["pair.center_distance"], face, g["model.user_stiffness"] * face)


def prepare(case: Case, generic_fmu: pathlib.Path, workdir: pathlib.Path) -> Prepared:
    """Parameters, resources (a scene FMU for level 1 and 5), geometry, load, start state."""
    from gearmesh.stability.cases import BASE

    params = {**BASE, **case.params}
    fmu_path = pathlib.Path(generic_fmu)
    resources = dict(case.resources)
    if case.fe_scene:
        from gearmesh.compliance import with_databases
        from gearmesh.scene import load_scene

        scene_file = workdir / f"{case.name}.toml"
        scene_file.write_text(case.fe_scene, encoding="utf-8")
        scene = with_databases(load_scene(scene_file, fmu_path), progress=False)
        params = {**scene.parameters, **BASE, **case.params}
        resources.update(scene.resources)
    if resources:
        from gearmesh.scene_fmu import build_scene_fmu

        fmu_path = build_scene_fmu(generic_fmu, {}, resources, workdir / f"{case.name}.fmu")
    if case.above_tight is not None:  # the gears' tight-mesh distance, as the FMU computes it
        tight = geometry(fmu_path, params).tight
        params["pair.center_distance"] = tight + case.above_tight
    geo = geometry(fmu_path, params)
    inputs = {k: _value(v, geo) for k, v in case.inputs.items()}
    load = float(_value(case.load, geo))
    resolved = dataclasses.replace(case, load=load)
    te0 = case.te0
    if te0 == "static":
        w1 = case.speed_rpm * 2 * math.pi / 60
        te0 = float(quasi_static_te(fmu_path, params, inputs, load, np.array([0.0]), w1,
                                    geo.ratio * w1)[0])
    pair = (case.pair or driven_pair)(resolved, geo, te0)
    return Prepared(resolved, fmu_path, params, inputs, geo, load, pair)


def quasi_static_te(fmu_path, params, inputs, load, phi1, omega1, omega2) -> np.ndarray:
    """The quasi-static TE of the same FMU (model.quasi_static, mesh.load_torque) at each gear-1
    angle, speeds and load (a number or one per angle): a case's starting equilibrium."""
    out = []
    omega1, omega2 = np.broadcast_to(omega1, phi1.shape), np.broadcast_to(omega2, phi1.shape)
    loads = np.broadcast_to(load, phi1.shape)
    with GearMeshFMU(fmu_path, {**params, "model.quasi_static": True}) as f:
        f.set(inputs)
        for a, w1, w2, q in zip(phi1, omega1, omega2, loads):
            f.step({"gear1.phi": float(a), "gear1.omega": float(w1), "gear2.omega": float(w2),
                    "mesh.load_torque": float(q)}, 1e-3)
            out.append(f.get(["mesh.te"])["mesh.te"])
    return np.array(out)


def step_sizes(h: float, seed: int = 7):
    """Communication steps drawn log-uniformly in [h/10, h] (the random-steps case)."""
    rng = np.random.default_rng(seed)
    while True:
        yield float(h * 10 ** rng.uniform(-1, 0))


def run(prep: Prepared, mode: str, h: float) -> Run:
    if mode not in MODES:
        raise ValueError(f"--modes: unknown mode {mode!r}; allowed: {', '.join(MODES)}")
    r = Run(prep.case.name, mode, h)
    if prep.case.modes and mode not in prep.case.modes:
        r.error = f"n/a: the case runs in {', '.join(prep.case.modes)} only"
        return r
    start = time.perf_counter()
    try:
        if mode in ("explicit", "implicit"):
            _run_master(prep, h, mode == "implicit", r)
        elif mode == "large_step":
            _run_signals(prep, h, r)
        else:
            _run_chain(prep, h, r)
    except (FMUError, RuntimeError, ValueError, KeyError, OverflowError, np.linalg.LinAlgError) as exc:
        r.error = str(exc).splitlines()[0][:300]
        if "converge" in r.error:
            r.unconverged += 1
    r.seconds = time.perf_counter() - start
    r.nan_count += int(np.count_nonzero(~np.isfinite(r.te)) + np.count_nonzero(~np.isfinite(r.force)))
    if prep.case.te_check and not r.error and len(r.phi1):
        if mode == "large_step_chain":
            r.te_ref = cut_reference_te(prep, r.t)
            r.te_cut = converged_te(prep, "chain", r.t)
        else:
            r.te_ref = converged_te(prep, "pair", r.t)
    return r


def reference_step(prep: Prepared) -> float:
    """The TE reference's step: REFERENCE_STEP unless the case needs a finer one."""
    return prep.case.reference_step or REFERENCE_STEP


def converged_te(prep: Prepared, plant: str, times: np.ndarray) -> np.ndarray:
    """The TE of the converged dynamics of the same system at the given times: the plain element
    (model.dynamics 0) under the implicit master (gearmesh.drivetrain, trapezoidal rule, Newton)
    at REFERENCE_STEP, an integrator and code path independent of the large-step mode. plant:
    "pair" (the case's GearPair: the modes explicit, implicit, large_step) or "chain" (the
    machine and load inertia of large_step_chain, as gearmesh.drivetrain's DrivetrainPlant).
    Computed once per case and plant."""
    if plant not in prep.converged:
        with GearMeshFMU(prep.fmu_path, prep.params) as fmu:
            fmu.set(prep.inputs)
            model = chain_plant(prep, fmu) if plant == "chain" else GearPairPlant(prep.pair)
            master = Integrator(fmu, model, reference_step(prep), True)
            master.advance(prep.case.t_end)
            res = master.result()
        prep.converged[plant] = (res.t[1:], np.asarray(res.mesh["mesh.te"], float))
    t, te = prep.converged[plant]
    return np.interp(times, t, te)


def chain_plant(prep: Prepared, fmu: GearMeshFMU) -> DrivetrainPlant:
    """large_step_chain's system (_run_chain) as a plant of the implicit master: machine (PI),
    drive shaft, gear 1, mesh, gear 2, shaft, load inertia with the load torque; the same start
    state. Cases with a speed-driven gear 1 and a constant load only."""
    case, pair = prep.case, prep.pair
    s1 = pair.shaft1
    if not s1.stiffness > 0 or pair.torque1(0.0) != 0.0:
        raise ValueError(f"{case.name}: the converged chain needs a speed-driven gear 1")
    scale = s1.stiffness / SHAFT_K
    load_torque = pair.torque2(0.0)
    p = Drivetrain(speed_rpm=s1.omega * 60 / (2 * math.pi), brake_torque=abs(load_torque),
                   J_motor=CHAIN_J * scale, J1=pair.J1, J2=pair.J2, J_load=CHAIN_J,
                   k1=s1.stiffness, c1=s1.damping, k2=SHAFT_K, c2=SHAFT_C, kp=CHAIN_KP * scale,
                   ki=CHAIN_KI * scale, spin_up=0.0)
    plant = DrivetrainPlant(fmu, p)
    if not math.isclose(p.brake_torque * plant._brake_sign(), load_torque, abs_tol=1e-12):
        raise ValueError(f"{case.name}: the load torque {load_torque:g} N m does not resist the "
                         "flank-A drive")
    x0 = pair.x0
    plant.x0[:9] = [s1.phi0, x0[1], s1.stiffness * s1.phi0 / p.ki, x0[0], x0[1], x0[2], x0[3],
                    x0[2] + load_torque / SHAFT_K, x0[3]]
    return plant


# ---- (a), (b): the project's masters --------------------------------------------------------

def _run_master(prep: Prepared, h: float, implicit: bool, r: Run) -> None:
    case = prep.case
    with GearMeshFMU(prep.fmu_path, prep.params) as fmu:
        fmu.set(prep.inputs)
        plant = GearPairPlant(prep.pair)
        master = Integrator(fmu, plant, h, implicit)
        sizes = step_sizes(h) if case.random_steps else None
        try:
            if case.rollback:
                master.advance(case.t_end / 2, sizes)
                saved = master.snapshot()
                master.advance(case.t_end, sizes)
                first = master.result()
                master.restore(saved)
                master.forget(saved)
                master.advance(case.t_end, sizes)
                again = master.result()
                n = min(len(first.t), len(again.t))
                r.rollback_gap = float(np.max(np.abs(first.x[:n] - again.x[:n]))) if \
                    len(first.t) == len(again.t) else math.inf
            else:
                master.advance(case.t_end, sizes)
        finally:
            res = master.result()
            r.retries = res.retries
            r.steps = len(res.t) - 1
            if r.steps:
                r.t, r.phi1 = res.t[1:], res.x[1:, 0]
                r.omega = (res.x[1:, 1], res.x[1:, 3])
                r.te, r.force = res.mesh["mesh.te"], res.mesh["mesh.normal_force"]
                r.flank = res.mesh["mesh.flank"]
                r.nan_count = int(np.count_nonzero(~np.isfinite(res.x)))
        e = res.energy
        r.residual, r.work_in = e["residual"], e["work_in"]


# ---- (c): the large-step mode ---------------------------------------------------------------

def large_step_parameters(prep: Prepared, shafts: tuple[Shaft, Shaft]) -> dict:
    """model.dynamics 1 with the pair's inertias, shafts and start state."""
    pair = prep.pair
    p = {**prep.params, **LARGE_STEP, "model.dynamics": 1,
         "gear1.inertia": pair.J1, "gear2.inertia": pair.J2}
    for i, s in enumerate(shafts, start=1):
        p[f"gear{i}.shaft_stiffness"] = s.stiffness
        p[f"gear{i}.shaft_damping"] = s.damping
    p.update({"gear1.phi": pair.x0[0], "gear1.omega": pair.x0[1],
              "gear2.phi": pair.x0[2], "gear2.omega": pair.x0[3]})
    return p


OUT = ["gear1.angle", "gear1.speed", "gear2.angle", "gear2.speed", "gear1.shaft_torque",
       "gear2.shaft_torque", "mesh.te", "mesh.normal_force", "mesh.flank", "energy.residual",
       "energy.work_in", "energy.kinetic", "energy.elastic", "dynamics.steps", "dynamics.rejected",
       "energy.initial"]


def _run_signals(prep: Prepared, h: float, r: Run) -> None:
    from fmpy import simulate_fmu

    case, pair = prep.case, prep.pair
    if case.random_steps or case.rollback:
        raise ValueError("n/a: simulate_fmu takes fixed steps and does not roll back")
    unzip, md = _unpacked(str(pathlib.Path(prep.fmu_path).resolve()))
    n = int(round(case.t_end / h))
    t = np.arange(n + 1) * h
    start = {**large_step_parameters(prep, pair.shafts), **prep.inputs}
    # every Real input is a signal (fmpy warns of each missing one): held ones at their start
    names = [v.name for v in md.modelVariables if v.causality == "input" and v.type == "Real"]
    signal = np.zeros(n + 1, dtype=[("time", float)] + [(k, float) for k in names])
    signal["time"] = t
    for k in names:
        signal[k] = start.pop(k, 0.0)
    for i, (torque, shaft) in enumerate(zip(pair.torques, pair.shafts), start=1):
        signal[f"gear{i}.torque"] = [torque(x) for x in t]
        signal[f"gear{i}.shaft_phi"] = [shaft.phi(x) for x in t]
        signal[f"gear{i}.shaft_omega"] = [shaft.rate(x) for x in t]
    messages = []
    try:
        res = _simulate(simulate_fmu, unzip, md, start, signal, h, t, messages)
    except FMICallException as exc:
        r.error = f"{exc}: {messages[-1] if messages else 'no message'}"
        if "converge" in r.error or "Discard" in r.error or "discard" in r.error:
            r.unconverged += 1
        return
    r.steps = len(res) - 1
    if res["time"][-1] < t[-1] - 0.5 * h:
        r.error = f"simulate_fmu stopped at t = {res['time'][-1]:g} s: {messages[-1] if messages else ''}"
        r.unconverged += 1
    _collect(r, res, res["time"], prep.geo.sign)


def _simulate(simulate_fmu, unzip, md, start, signal, h, t, messages):
    return simulate_fmu(unzip, model_description=md, start_values=start, input=signal,
                        output=OUT, step_size=h, output_interval=h, stop_time=t[-1],
                        fmi_type="CoSimulation", validate=False,
                        debug_logging=True,
                        logger=lambda *a: messages.append(a[-1].decode(errors="replace")
                                                          if isinstance(a[-1], bytes) else str(a[-1])))


def _collect(r: Run, res, t, sign: int = 1) -> None:
    r.t, r.phi1 = np.asarray(t[1:]), np.asarray(res["gear1.angle"][1:])
    r.omega = (np.asarray(res["gear1.speed"][1:]), np.asarray(res["gear2.speed"][1:]))
    r.te, r.force = np.asarray(res["mesh.te"][1:]), np.asarray(res["mesh.normal_force"][1:])
    r.flank = np.asarray(res["mesh.flank"][1:])
    r.residual = float(res["energy.residual"][-1])
    r.internal_steps = int(np.sum(res["dynamics.steps"][1:]))
    r.rejected = int(np.sum(res["dynamics.rejected"][1:]))
    # the scale of the residual: the initial energy and the work put in, as the FMU integrates it
    # at its internal steps (a quadrature of the sampled torques misses what varies within a
    # communication step: edge contact under a 20 mrad tilt, wedging)
    r.work_in = float(res["energy.initial"][-1]) + float(res["energy.work_in"][-1])
    r.largest_energy = float(np.max(np.asarray(res["energy.kinetic"], float)
                                    + np.asarray(res["energy.elastic"], float)))
    r.nan_count = sum(int(np.count_nonzero(~np.isfinite(np.asarray(res[k], float)))) for k in OUT)


class ChainSide:
    """large_step_chain's Python side: the driving machine (PI speed control; present when gear 1
    is speed-driven) and the load inertia with the load torque, coupled to the gear pair through
    the shafts by an explicit cut. Symplectic Euler per communication step: the far-end angles
    with the speeds held over the step (as the FMU moves them), then the speeds from the shaft
    torques on the gears at the end of the step."""

    def __init__(self, prep: Prepared):
        pair = prep.pair
        s1 = pair.shaft1
        self.drive = s1.stiffness > 0                 # gear 1 speed-driven: a motor on its shaft
        self.shaft1 = s1 if self.drive else Shaft()
        self.shaft2 = Shaft(SHAFT_K, SHAFT_C)         # gear 2 always on a shaft to the load
        self.w_ref = s1.omega
        # the machine's inertia and controller scale with the drive shaft (scaled with gear 1's
        # inertia, shaft_for), so that the coupling mode across the cut stays at ~100 rad/s
        scale = s1.stiffness / SHAFT_K if self.drive else 1.0
        self.J_m, self.kp, self.ki = CHAIN_J * scale, CHAIN_KP * scale, CHAIN_KI * scale
        self.load_torque = pair.torque2
        self.torque1 = pair.torque1
        # machine (phi_m, w_m, integral), load (phi_L, w_L): start in equilibrium
        self.m = np.array([s1.phi0, pair.x0[1],
                           s1.stiffness * s1.phi0 / self.ki if self.drive else 0.0])
        self.L = np.array([pair.x0[2] + self.load_torque(0.0) / SHAFT_K, pair.x0[3]])

    def inputs(self, t: float) -> dict:
        """The FMU's inputs over the step from t: far ends and gear 1's torque, held."""
        m, L = self.m, self.L
        return {"gear1.torque": self.torque1(t), "gear2.torque": 0.0,
                "gear1.shaft_phi": m[0] if self.drive else 0.0,
                "gear1.shaft_omega": m[1] if self.drive else 0.0,
                "gear2.shaft_phi": L[0], "gear2.shaft_omega": L[1]}

    def shafts(self, t: float) -> tuple[Shaft, Shaft]:
        """The shafts with their far ends moving from t as the FMU moves them over a step."""
        u = self.inputs(t)
        return tuple(Shaft(s.stiffness, s.damping,
                           phi0=u[f"gear{i}.shaft_phi"] - u[f"gear{i}.shaft_omega"] * t,
                           omega=u[f"gear{i}.shaft_omega"])
                     for i, s in ((1, self.shaft1), (2, self.shaft2)))

    def advance(self, t: float, dt: float, shaft_torque1: float, shaft_torque2: float) -> None:
        m, L = self.m, self.L
        if self.drive:
            m[0] += dt * m[1]
            m[2] += dt * (self.w_ref - m[1])
            T_m = self.kp * (self.w_ref - m[1]) + self.ki * m[2]
            m[1] += dt * (T_m - shaft_torque1) / self.J_m
        L[0] += dt * L[1]
        L[1] += dt * (self.load_torque(t + dt) - shaft_torque2) / CHAIN_J


def cut_reference_te(prep: Prepared, times: np.ndarray) -> np.ndarray:
    """large_step_chain's TE with the FMU's part converged: the same chain, the same explicit cut
    at the same communication points, the gear pair between them integrated by the plain element
    under the implicit master at REFERENCE_STEP (the far ends moving and gear 1's torque held as
    the FMU has them). The difference from a large_step_chain run is the FMU's own error; the
    difference from converged_te(prep, "chain", ...) is the explicit cut's (docs/stability.md)."""
    side = ChainSide(prep)
    pair = dataclasses.replace(prep.pair, torque2=lambda t: 0.0, shaft1=side.shafts(0.0)[0],
                               shaft2=side.shafts(0.0)[1])
    te = []
    with GearMeshFMU(prep.fmu_path, prep.params) as fmu:
        fmu.set(prep.inputs)
        plant = GearPairPlant(pair)
        master = Integrator(fmu, plant, reference_step(prep), True)
        t = 0.0
        for t_next in times:
            torque1 = side.torque1(t)
            pair.torque1 = lambda _t, value=torque1: value
            pair.shaft1, pair.shaft2 = side.shafts(t)
            master.advance(t_next)
            x = master.x
            side.advance(t, t_next - t, pair.shaft1.torque(t_next, x[0], x[1]),
                         pair.shaft2.torque(t_next, x[2], x[3]))
            te.append(master.rows["mesh.te"][-1])
            t = t_next
    return np.array(te)


def _run_chain(prep: Prepared, h: float, r: Run) -> None:
    """The driving machine and the load inertia in Python (ChainSide), coupled through the
    shafts."""
    case, pair, geo = prep.case, prep.pair, prep.geo
    side = ChainSide(prep)
    chain_pair = dataclasses.replace(pair, torque2=lambda t: 0.0, shaft2=side.shaft2)
    params = large_step_parameters(dataclasses.replace(prep, pair=chain_pair),
                                   (side.shaft1, side.shaft2))
    # the far ends' start state before initialization (the FMU's initial energy counts it)
    params.update(side.inputs(0.0))
    sizes = step_sizes(h) if case.random_steps else None
    rows = {k: [] for k in OUT}
    times = [0.0]
    with GearMeshFMU(prep.fmu_path, params) as fmu:
        fmu.set(prep.inputs)
        first = fmu.get(OUT)
        for k in OUT:
            rows[k].append(first[k])

        def one(t, dt):
            fmu.set(side.inputs(t))
            fmu._call(fmu.fmu.doStep, currentCommunicationPoint=t, communicationStepSize=dt)
            out = fmu.get(OUT)
            side.advance(t, dt, out["gear1.shaft_torque"], out["gear2.shaft_torque"])
            return out

        t = 0.0
        saved = None
        try:
            while t < case.t_end - 1e-12:
                if case.rollback and saved is None and t >= case.t_end / 2:
                    saved = (fmu.fmu.getFMUstate(), t, side.m.copy(), side.L.copy(), len(times))
                dt = min(next(sizes) if sizes else h, case.t_end - t)
                out = one(t, dt)
                t += dt
                times.append(t)
                for k in OUT:
                    rows[k].append(out[k])
            if saved is not None:
                state, t, side.m, side.L, n = saved
                first_run = {k: np.array(v) for k, v in rows.items()}
                fmu.fmu.setFMUstate(state)
                fmu.fmu.freeFMUstate(state)
                for k in OUT:
                    del rows[k][n:]
                del times[n:]
                while t < case.t_end - 1e-12:
                    dt = min(h, case.t_end - t)
                    out = one(t, dt)
                    t += dt
                    times.append(t)
                    for k in OUT:
                        rows[k].append(out[k])
                again = {k: np.array(v) for k, v in rows.items()}
                r.rollback_gap = max(float(np.max(np.abs(first_run[k] - again[k])))
                                     for k in ("gear1.angle", "gear2.angle", "mesh.te"))
        finally:
            r.steps = len(times) - 1
            res = {k: np.array(v, dtype=float) for k, v in rows.items()}
            _collect(r, res, np.array(times), geo.sign)
