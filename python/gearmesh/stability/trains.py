"""`gearmesh stability --trains`: the train scenes of scenarios/trains under an explicit
co-simulation master, damped and undamped, at communication steps of 1e-3 and 1e-2 s, each run
judged (docs/stability.md, "Gear trains").

The master (`run`) is what a system simulator with a separate motor FMU does: a motor inertia
(motor_inertia, see COUPLING) integrated by the master explicitly (symplectic Euler, as
gearmesh.stability.runs.ChainSide: the far end's angle with the speed the FMU held, then the
speed from the port shaft's torque output at the end of the step), its angle and speed fed back
to the train FMU as the port's far_phi and far_omega; one fmi2DoStep of the train FMU (fmpy's
FMU2Slave through gearmesh.fmu_driver) per communication step. The train starts at rest at its
scene's angles. The motor's torque (Drive): the load through the train's ratio, plus a constant
spin-up torque (J_eq w_ref / SPIN_UP, J_eq the motor's and the train's inertia at the port) that
ramps the train up to the scene's [run] port_speed_rpm over SPIN_UP, plus a PI speed hold on that
ramped reference (time constant HOLD), which keeps the train at a steady speed and supplies its
losses (a back-to-back rig's: its port carries no load). The load: [run] load_Nm on [run]
load_body, constant from the start, against the body's turning. Every scene has a port (the
back-to-back rig's motor shaft included), so every scene runs driven.

Cases: each scene damped (as the scene is) and undamped: every mesh's contact damping 0 and the
shafts between bodies undamped, written as modified copies of the pair scenes and the train scene
into the work folder (undamped_copy). A port shaft keeps its damping (the port is the master's
side) and a mesh keeps its friction (the idler's set-B mesh and the back-to-back rig's set-A
meshes have mu 0.35 and 0.4: the pair scene's physics, a loss, not a damper).

Judgement of a run (judge): no FMI error (an error or a discarded step ends the run); every
output finite; the speeds bounded (every body and the motor within SPEED_LIMIT x the largest body
speed of the train's kinematics at the reference speed); energy, from the train FMU's own account
(energy.residual: + lost, - made), as for the pair: damped runs |residual| <= ENERGY_TOL of the
work in (initial energy + energy.work_in); undamped runs: the energy made (-residual) <=
UNDAMPED_GAIN of the run's largest kinetic + elastic energy plus THROUGHPUT_DRIFT of the work
that passed through the train (energy.work_in). The second term is the train's own: a pair under
balanced torques passes no power, a loaded train passes kilowatts, and the account's residual
then drifts with the throughput, steadily and of either sign (-3.5 to +1.5 mW over 2.5 kW in
the 10 s runs, at most 3e-6 of the power, damped or not: TR-BDF2's local error on the power
integrals, within its tolerance), which a fixed fraction of the stored energy would fail once a
run is long enough (the undamped 3-planet stage at 1e-3 s crosses 1e-3 of its 33 J at 9.5 s).
An oscillation that feeds itself grows with the stored energy, not with the throughput, and the
envelope rule below sees it; and the undamped runs at a steady
speed (the port body's mean speed over both windows within STEADY_TOL of the reference): each
mesh's TE envelope (peak to peak of the TE at the communication points) over the last TE_WINDOW
no wider than over the first TE_WINDOW of the steady part (from STEADY_START), plus the mesh's
ripple: the TE's peak to peak over TE_WINDOW in the damped scene, steady, at REFERENCE_STEP
(reference_ripple). The envelope at the communication points is the mesh oscillation plus the
ripple of the tooth mesh (10 Hz to 0.3 kHz at the scenes' speeds) at the phases the samples hit:
sampled at 1e-2 s, the undamped 3-planet stage's ring meshes (250.7 Hz) show 0.29 to 1.6 um over
successive 0.25 s windows, in turn with a period of 0.75 s, where the same run at 1e-3 s shows
1.2 to 1.7 um. The ripple is what the samples can catch in one window and miss in another; a
growth beyond it is the oscillation's.
"""
from __future__ import annotations

import json
import math
import pathlib
import re
import shutil
import tempfile
import time
import tomllib
from dataclasses import asdict, dataclass, field

import numpy as np
from tqdm import tqdm

from gearmesh.paths import Paths
from gearmesh.stability.suite import ENERGY_TOL, UNDAMPED_GAIN, _fmt, _mark, parse_steps
from gearmesh.train_fmu import Train, build_train_fmu, kinematic_speeds, load_train

THROUGHPUT_DRIFT = 1e-5  # of the work passed through: the account's drift an undamped run may show

SCENES = ["two_stage_reducer", "idler", "planetary_3_planets", "planetary_4_planets",
          "back_to_back_set_a"]
STEPS = [1e-3, 1e-2]
RPM = 2 * math.pi / 60

DURATION = 10.0         # s of simulated time per run (docs/stability.md, "Gear trains": the time)
# The motor's inertia: the port shaft's stiffness x COUPLING^2, i.e. the port shaft between the
# motor and a train held still has its mode at 1 / COUPLING = 100 rad/s (as the pair suite's
# chain, gearmesh.stability.runs.ChainSide): the master's explicit step (symplectic Euler, stable
# for omega h < 2) is then stable at 1e-2 s with a margin of 2 even where the train sticks in its
# friction (the back-to-back rig at 10 rpm). 1 to 2 kg m^2 here, 100 to 1000 x the port body's
# inertia; with 10 x (0.2 kg m^2 on the rig's 2e4 N m/rad shaft: omega h = 3.2) the rig at 1e-2 s
# swings beyond the speed bound (docs/stability.md, "Gear trains").
COUPLING = 1e-2         # s
SPIN_UP = 0.2           # s: the spin-up torque brings the train to the reference speed in this
HOLD = 0.05             # s: the speed hold's time constant (PI: K_p = 2 J_eq / HOLD, K_i = J_eq / HOLD²)
SPEED_LIMIT = 3.0       # bounded: |speed| <= this x the largest body speed at the reference
STEADY_START = 0.5      # s: the steady part starts here (spin-up and the hold's approach done)
STEADY_TOL = 0.05       # steady: the port body's mean speed over each window within 5 % of the reference
TE_WINDOW = 1.0         # s: the first and the last window of the steady part
REFERENCE_STEP = 1e-3   # s: the damped scene's run that measures each mesh's ripple


@dataclass
class TrainCase:
    scene: str
    damped: bool

    @property
    def name(self) -> str:
        return f"{self.scene} {'damped' if self.damped else 'undamped'}"


def cases(names: list[str] | None = None) -> list[TrainCase]:
    """Every scene damped and undamped (names: scenes, or `scene:damped` / `scene:undamped`);
    an unknown name is an error naming the known ones."""
    if not names:
        return [TrainCase(s, d) for s in SCENES for d in (True, False)]
    out = []
    for n in names:
        scene, _, which = n.partition(":")
        if scene not in SCENES or which not in ("", "damped", "undamped"):
            raise ValueError(f"--cases: unknown train case {n!r}; known: {', '.join(SCENES)} "
                             "(each optionally :damped or :undamped)")
        out += [TrainCase(scene, d) for d in (True, False)
                if not which or d == (which == "damped")]
    return out


# ---- the undamped copies ------------------------------------------------------------------------

_BARE = re.compile(r"[A-Za-z0-9_-]+")


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)  # a TOML basic string (JSON's escapes are TOML's)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"no TOML text for {v!r}")


def toml_text(data: dict) -> str:
    """TOML of what tomllib read from a scene: tables, arrays of tables, scalars and lists."""
    lines: list[str] = []

    def key(k: str) -> str:
        return k if _BARE.fullmatch(k) else json.dumps(k)

    def table(prefix: str, d: dict, header: str) -> None:
        if header:
            lines.extend(["", header])
        for k, v in d.items():
            if not isinstance(v, dict) and not (isinstance(v, list) and v and isinstance(v[0], dict)):
                lines.append(f"{key(k)} = {_toml_value(v)}")
        for k, v in d.items():
            name = f"{prefix}.{key(k)}" if prefix else key(k)
            if isinstance(v, dict):
                table(name, v, f"[{name}]")
            elif isinstance(v, list) and v and isinstance(v[0], dict):
                for item in v:
                    table(name, item, f"[[{name}]]")

    table("", data, "")
    return "\n".join(lines).lstrip("\n") + "\n"


def undamped_copy(train_scene: pathlib.Path, folder: pathlib.Path) -> pathlib.Path:
    """The train scene with every mesh's contact damping 0 and its shafts between bodies
    undamped, as files in folder: each pair scene copied with [model] damping_Ns_per_m2 = 0
    (files it names copied beside it), the train scene pointing at the copies. Port shafts keep
    their damping. Returns the train scene's copy."""
    folder.mkdir(parents=True, exist_ok=True)
    train = tomllib.loads(train_scene.read_text(encoding="utf-8"))
    copies: dict[pathlib.Path, str] = {}
    for mesh in train.get("mesh", []):
        source = (train_scene.parent / mesh["scene"]).resolve()
        if source not in copies:
            name = f"{source.stem}.toml"
            while name in copies.values():
                name = f"{pathlib.Path(name).stem}_{len(copies)}.toml"
            pair = tomllib.loads(source.read_text(encoding="utf-8"))
            pair.setdefault("model", {})["damping_Ns_per_m2"] = 0.0
            _copy_files(pair, source.parent, folder)
            (folder / name).write_text(toml_text(pair), encoding="utf-8")
            copies[source] = name
        mesh["scene"] = copies[source]
    for shaft in train.get("shaft", []):
        if shaft.get("other") != "port":
            shaft["damping_Nms_per_rad"] = 0.0
    out = folder / train_scene.name
    out.write_text(toml_text(train), encoding="utf-8")
    return out


def _copy_files(data: dict, source: pathlib.Path, folder: pathlib.Path) -> None:
    """Copy the files a pair scene names (keys ending in _file, relative to its folder) beside
    its copy."""
    if "resource_root" in data.get("scene", {}):
        raise ValueError(f"{source}: a pair scene with [scene] resource_root has no undamped copy here")
    for k, v in data.items():
        if isinstance(v, dict):
            _copy_files(v, source, folder)
        elif k.endswith("_file") and isinstance(v, str):
            target = folder / v
            if not target.resolve().is_relative_to(folder.resolve()):
                raise ValueError(f"{source}: {k} = {v!r} lies outside the scene's folder")
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy(source / v, target)


# ---- the train's kinematics ---------------------------------------------------------------------

def speed_ratios(train: Train, generic_fmu: pathlib.Path) -> np.ndarray:
    """Each body's speed per unit speed of the port body (gearmesh.train_fmu.kinematic_speeds)."""
    from gearmesh.scene import load_scene

    scenes = [load_scene(m["_scene"], generic_fmu) for m in train.meshes]
    return kinematic_speeds(train, scenes, port_shaft(train)["_body"], strict=True)


def port_shaft(train: Train) -> dict:
    ports = [s for s in train.shafts if s["_other"] == -1]
    if len(ports) != 1:
        raise ValueError(f"{train.path}: the master drives one port shaft; the scene has {len(ports)}")
    return ports[0]


# ---- one run ------------------------------------------------------------------------------------

@dataclass
class Prepared:
    case: TrainCase
    fmu: pathlib.Path
    train: Train
    ratio: np.ndarray


def prepare(case: TrainCase, generic_fmu: pathlib.Path, workdir: pathlib.Path) -> Prepared:
    """The case's train scene (the scene itself, or its undamped copy) built into an FMU."""
    scene = Paths.resolve().require("scenes") / "trains" / f"{case.scene}.toml"
    folder = workdir / case.name.replace(" ", "_")
    if not case.damped:
        scene = undamped_copy(scene, folder)
    train = load_train(scene)
    fmu = build_train_fmu(scene, folder / f"{train.name}.fmu", generic_fmu)
    return Prepared(case, fmu, train, speed_ratios(train, generic_fmu))


@dataclass
class Drive:
    """The master's side: the motor and the load, from the scene's [run] table. The motor's
    torque: the load through the train's ratio, the spin-up torque J_eq w_ref / SPIN_UP while the
    reference speed ramps up, and a PI speed hold on the ramped reference (which also supplies the
    train's losses)."""
    J_m: float
    J_eq: float            # motor + train at the port
    w_ref: float           # rad/s at the port
    T_ff: float            # the load through the ratio
    K_p: float             # N m s/rad
    K_i: float             # N m/rad
    load_body: str
    load: float            # torque on load_body, N m (against its turning)

    def reference(self, t: float) -> float:
        return self.w_ref * min(1.0, t / SPIN_UP)

    def torque(self, t: float, w_m: float, angle_error: float) -> float:
        """At t, with the motor at w_m and the integral of the speed error angle_error."""
        spin_up = self.J_eq * self.w_ref / SPIN_UP if t < SPIN_UP else 0.0
        return self.T_ff + spin_up + self.K_p * (self.reference(t) - w_m) + self.K_i * angle_error


def motor_inertia(train: Train) -> float:
    """The motor's inertia: the port shaft's stiffness x COUPLING^2 (see COUPLING)."""
    return float(port_shaft(train).get("stiffness_Nm_per_rad", 0.0)) * COUPLING ** 2


def drive(prep: Prepared, J_m: float | None = None) -> Drive:
    train, ratio = prep.train, prep.ratio
    run = train.run
    J_m = motor_inertia(train) if J_m is None else J_m
    J_eq = J_m + sum(b["_inertia"] * r * r for b, r in zip(train.bodies, ratio) if not b["_fixed"])
    w_ref = float(run.get("port_speed_rpm", 100.0)) * RPM
    load_body = run.get("load_body", "")
    load_Nm = float(run.get("load_Nm", 0.0)) if load_body else 0.0
    r_load = ratio[[b["name"] for b in train.bodies].index(load_body)] if load_body else 0.0
    w_c = 1.0 / HOLD
    return Drive(J_m, J_eq, w_ref, load_Nm * abs(r_load), 2 * J_eq * w_c, J_eq * w_c * w_c,
                 load_body, -math.copysign(load_Nm, r_load) if load_body else 0.0)


@dataclass
class TrainRun:
    case: str
    step: float
    error: str = ""
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    speeds: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))  # bodies x samples
    motor: np.ndarray = field(default_factory=lambda: np.zeros(0))
    te: dict = field(default_factory=dict)        # mesh -> TE at the samples
    energy: dict = field(default_factory=dict)    # energy.* -> samples
    nan_count: int = 0
    steps: int = 0
    internal_steps: int = 0
    rejected: int = 0
    seconds: float = 0.0
    w_ref: float = math.nan                       # the port body's reference speed
    port_column: int = 0                          # the port body's row of speeds
    speed_bound: float = math.nan                 # rad/s


ENERGY = ["energy.kinetic", "energy.elastic", "energy.initial", "energy.work_in", "energy.work_out",
          "energy.friction", "energy.damping", "energy.parametric", "energy.residual"]


def run(prep: Prepared, h: float, duration: float = DURATION,
        motor: float | None = None) -> TrainRun:
    """The case at communication step h for `duration` s under the explicit master (motor: the
    motor's inertia, default motor_inertia)."""
    from gearmesh.fmu_driver import FMUError, GearMeshFMU

    train, d = prep.train, drive(prep, motor)
    port = port_shaft(train)
    p = port["name"]
    r = TrainRun(prep.case.name, h, w_ref=d.w_ref, port_column=port["_body"],
                 speed_bound=SPEED_LIMIT * d.w_ref * float(np.max(np.abs(prep.ratio))))
    bodies = [b["name"] for b in train.bodies]
    meshes = [m["name"] for m in train.meshes]
    real = [f"{b}.speed" for b in bodies] + [f"{m}.te" for m in meshes] + ENERGY + [f"{p}.torque"]
    rows, motor_speed, steps, rejected = [], [], 0, 0
    phi_m = w_m = t = angle_error = 0.0
    n = int(round(duration / h))
    start = time.perf_counter()
    with GearMeshFMU(prep.fmu, instance_name=train.name) as fmu:
        refs = [fmu.variables[v].valueReference for v in real]
        counters = [fmu.variables[v].valueReference for v in ("dynamics.steps", "dynamics.rejected")]
        inputs = [f"{p}.far_phi", f"{p}.far_omega"] + ([f"{d.load_body}.torque"] if d.load_body else [])
        in_refs = [fmu.variables[v].valueReference for v in inputs]
        rows.append(fmu._call(fmu.fmu.getReal, refs))
        motor_speed.append(0.0)
        try:
            for k in range(n):
                t = k * h
                fmu._call(fmu.fmu.setReal, in_refs, [phi_m, w_m] + ([d.load] if d.load_body else []))
                fmu._call(fmu.fmu.doStep, currentCommunicationPoint=t, communicationStepSize=h)
                out = fmu._call(fmu.fmu.getReal, refs)
                count = fmu._call(fmu.fmu.getInteger, counters)
                steps, rejected = steps + count[0], rejected + count[1]
                T_m = d.torque(t, w_m, angle_error)
                angle_error += h * (d.reference(t) - w_m)
                phi_m += h * w_m                         # the far end as the FMU moved it
                w_m += h * (T_m - out[-1]) / d.J_m       # the far end feels minus the shaft torque
                rows.append(out)
                motor_speed.append(w_m)
                if not all(math.isfinite(v) for v in out) or not math.isfinite(w_m):
                    r.error = f"non-finite values at t = {t + h:g} s"
                    break
                if max(abs(v) for v in out[:len(bodies)] + [w_m]) > 10 * r.speed_bound:
                    r.error = (f"diverged: a speed beyond {10 * r.speed_bound:.3g} rad/s at "
                               f"t = {t + h:g} s")
                    break
        except FMUError as exc:
            r.error = f"{'discarded' if exc.discarded else 'FMI error'} at t = {t:g} s: {exc}"
    r.seconds = time.perf_counter() - start
    x = np.array(rows, dtype=float)
    r.steps = len(rows) - 1
    r.t = np.arange(len(rows)) * h
    r.nan_count = (int(np.count_nonzero(~np.isfinite(x)))
                   + int(np.count_nonzero(~np.isfinite(motor_speed))))
    nb = len(bodies)
    r.speeds = x[:, :nb].T
    r.te = {m: x[:, nb + i] for i, m in enumerate(meshes)}
    r.energy = {e: x[:, nb + len(meshes) + i] for i, e in enumerate(ENERGY)}
    r.motor = np.array(motor_speed)
    r.internal_steps, r.rejected = steps, rejected
    return r


# ---- judgement ----------------------------------------------------------------------------------

def windows(r: TrainRun) -> tuple[np.ndarray, np.ndarray]:
    """The samples of the first and the last TE_WINDOW of the steady part (masks over r.t)."""
    first = (r.t > STEADY_START) & (r.t <= STEADY_START + TE_WINDOW + 1e-9)
    last = r.t > r.t[-1] - TE_WINDOW + 1e-9
    return first, last


def reference_ripple(prep: Prepared) -> dict[str, float]:
    """Each mesh's ripple: the peak to peak of its TE over the last TE_WINDOW of the damped
    scene (prep: a damped case) run at REFERENCE_STEP for STEADY_START + TE_WINDOW."""
    if not prep.case.damped:
        raise ValueError("the ripple is measured on the damped scene")
    r = run(prep, REFERENCE_STEP, STEADY_START + TE_WINDOW)
    if r.error:
        raise RuntimeError(f"{prep.case.name}: the ripple's reference run failed: {r.error}")
    last = windows(r)[1]
    return {m: float(np.ptp(te[last])) for m, te in r.te.items()}


@dataclass
class Verdict:
    passed: bool
    failed: list[str]
    notes: list[str]
    max_speed: float = math.nan      # the largest speed, of the bound
    residual: float = math.nan       # J, + lost
    scale: float = math.nan          # J: work in (damped) or the largest kinetic + elastic energy
    energy: float = math.nan         # damped: |residual| / work in; undamped: energy made / largest
    rate: float = math.nan           # W: the residual's slope over the steady part (- made)
    steady: bool | None = None
    mesh: str = ""                   # the mesh whose envelope came closest to its limit
    envelope: tuple = ()             # its (first, last, ripple), m


def judge(r: TrainRun, damped: bool, ripple: dict[str, float] | None = None) -> Verdict:
    """A run against the rules of the module's docstring (ripple: reference_ripple, needed for
    the undamped runs)."""
    failed, notes = [], []
    if r.error:
        failed.append(r.error)
    if r.nan_count:
        failed.append(f"{r.nan_count} non-finite values")
    v = Verdict(False, failed, notes)
    if not r.steps:
        failed.append("no step taken")
        return v
    speeds = np.abs(np.nan_to_num(np.vstack([r.speeds, r.motor[None, :]]), nan=np.inf))
    v.max_speed = float(np.max(speeds)) / r.speed_bound
    if not v.max_speed <= 1.0:
        failed.append(f"speed {np.max(speeds):.4g} rad/s beyond the bound {r.speed_bound:.4g} rad/s")
    e = r.energy
    v.residual = float(e["energy.residual"][-1])
    steady_part = r.t > STEADY_START
    if np.count_nonzero(steady_part) >= 2 and np.all(np.isfinite(e["energy.residual"][steady_part])):
        v.rate = float(np.polyfit(r.t[steady_part], e["energy.residual"][steady_part], 1)[0])
    if damped:
        v.scale = float(e["energy.initial"][-1] + e["energy.work_in"][-1])
        v.energy = abs(v.residual) / v.scale if v.scale > 0 else math.inf
        if not v.energy <= ENERGY_TOL:
            failed.append(f"energy residual {v.residual:+.3g} J: {v.energy:.3g} of the work in "
                          f"{v.scale:.3g} J (allowed {ENERGY_TOL:g})")
    else:
        v.scale = float(np.max(e["energy.kinetic"] + e["energy.elastic"]))
        v.energy = -v.residual / v.scale if v.scale > 0 else math.inf
        through = float(e["energy.work_in"][-1])
        allowed = UNDAMPED_GAIN * v.scale + THROUGHPUT_DRIFT * through
        if not -v.residual <= allowed:
            failed.append(f"energy made: {-v.residual:.3g} J, {v.energy:.3g} of the largest kinetic + elastic "
                          f"energy {v.scale:.3g} J (allowed {UNDAMPED_GAIN:g} of it plus {THROUGHPUT_DRIFT:g} of "
                          f"the {through:.3g} J passed through: {allowed:.3g} J)")
        _judge_envelopes(r, ripple, v)
    v.passed = not failed
    return v


def _judge_envelopes(r: TrainRun, ripple: dict[str, float] | None, v: Verdict) -> None:
    first, last = windows(r)
    complete = not r.error and r.t[-1] >= STEADY_START + 2 * TE_WINDOW - 1e-9
    w = r.speeds[r.port_column]
    v.steady = bool(complete and all(abs(np.mean(w[k]) / r.w_ref - 1) <= STEADY_TOL
                                     for k in (first, last)))
    if not v.steady:
        v.notes.append("not at a steady speed: the TE envelope is not judged")
        return
    if ripple is None:
        raise ValueError("the undamped runs' envelope needs the meshes' ripple (reference_ripple)")
    worst = -math.inf
    for mesh, te in r.te.items():
        a, b, c = float(np.ptp(te[first])), float(np.ptp(te[last])), ripple[mesh]
        use = (b - a) / c if c > 0 else (math.inf if b > a else 0.0)
        if use > worst:
            worst, v.mesh, v.envelope = use, mesh, (a, b, c)
        if not b <= a + c:
            v.failed.append(f"{mesh}: TE envelope grew from {a * 1e6:.3g} to {b * 1e6:.3g} um, "
                            f"beyond its ripple {c * 1e6:.3g} um")


# ---- the suite ----------------------------------------------------------------------------------

@dataclass
class TrainRow:
    scene: str
    damping: str
    step: float
    passed: bool
    max_speed: float        # of the bound
    residual: float         # J, + lost, - made
    scale: float            # J
    energy: float           # damped: |residual| / work in; undamped: made / largest energy
    rate: float             # W: the residual's slope over the steady part
    steady: bool | None
    mesh: str               # the mesh closest to its envelope limit
    envelope_first: float   # m
    envelope_last: float    # m
    ripple: float           # m
    cost: float             # s wall per communication step
    internal_steps: float   # per communication step
    seconds: float          # wall of the run
    simulated: float        # s
    failed: str


def row(case: TrainCase, r: TrainRun, ripple: dict[str, float] | None = None) -> TrainRow:
    v = judge(r, case.damped, ripple)
    first, last, rip = v.envelope or (math.nan,) * 3
    return TrainRow(case.scene, "damped" if case.damped else "undamped", r.step, v.passed,
                    v.max_speed, v.residual, v.scale, v.energy, v.rate, v.steady, v.mesh, first, last,
                    rip, r.seconds / r.steps if r.steps else math.nan,
                    r.internal_steps / r.steps if r.steps else math.nan, r.seconds,
                    float(r.t[-1]) if len(r.t) else 0.0, "; ".join(v.failed + v.notes))


def run_suite(generic_fmu: pathlib.Path, selected: list[TrainCase], steps: list[float],
              duration: float = DURATION, progress: bool = True) -> list[TrainRow]:
    """Every selected case at every step (the undamped ones with their scene's ripple, measured
    once per scene on the damped scene)."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="gearmesh-stability-trains-") as tmp:
        work = pathlib.Path(tmp)
        damped: dict[str, Prepared] = {}
        ripples: dict[str, dict[str, float]] = {}
        bar = tqdm(total=len(selected) * len(steps), disable=not progress, desc="trains")
        for case in selected:
            if case.scene not in damped and (case.damped or case.scene not in ripples):
                damped[case.scene] = prepare(TrainCase(case.scene, True), generic_fmu, work)
            if not case.damped and case.scene not in ripples:
                ripples[case.scene] = reference_ripple(damped[case.scene])
            prep = damped[case.scene] if case.damped else prepare(case, generic_fmu, work)
            for h in steps:
                bar.set_postfix_str(f"{case.name} {h:g}")
                rows.append(row(case, run(prep, h, duration), ripples.get(case.scene)))
                bar.update()
        bar.close()
    return rows


def table_lines(rows: list[TrainRow]) -> list[str]:
    lines = ["| scene | damping | step (s) | result | energy residual (J, + lost) | judged against (J) "
             "| energy judged | residual rate, steady part (mW) | largest speed (of the bound) | "
             "steady | TE envelope first → last, ripple (um), mesh | internal steps/step | "
             "cost/step (ms) | failed judgements, notes |", "|" + "---|" * 14]
    for r in rows:
        judged = (f"{_fmt(r.energy)} of the work in" if r.damping == "damped"
                  else f"made {_fmt(r.energy)} of the largest")
        steady = "–" if r.steady is None else ("yes" if r.steady else "no")
        env = (f"{r.envelope_first * 1e6:.3g} → {r.envelope_last * 1e6:.3g}, "
               f"{r.ripple * 1e6:.3g} ({r.mesh})" if r.mesh else "–")
        lines.append(f"| {r.scene} | {r.damping} | {r.step:g} | {_mark(r.passed)} | "
                     f"{r.residual:+.3g} | {_fmt(r.scale)} | {judged} | {r.rate * 1e3:+.3g} | "
                     f"{_fmt(r.max_speed)} | "
                     f"{steady} | {env} | {_fmt(r.internal_steps)} | {_fmt(r.cost, 1e3)} | "
                     f"{r.failed.replace('|', '/')} |")
    return lines


def summary_line(rows: list[TrainRow], seconds: float) -> str:
    per = ", ".join(f"{h:g} s: {sum(r.passed for r in rows if r.step == h)}/"
                    f"{sum(1 for r in rows if r.step == h)}" for h in sorted({r.step for r in rows}))
    return (f"{sum(r.passed for r in rows)} of {len(rows)} train runs pass ({per}); "
            f"{sum(r.simulated for r in rows):g} s simulated in {seconds:.0f} s wall.")


def _plain(v):
    """JSON of a row's value: NaN and infinities as null."""
    return None if isinstance(v, float) and not math.isfinite(v) else v


def write_outputs(rows: list[TrainRow], out: pathlib.Path, seconds: float) -> None:
    """results.md (the table) and results.json (the rows and the settings) in out."""
    out.mkdir(parents=True, exist_ok=True)
    md = ["# Stability suite: gear trains", "", summary_line(rows, seconds), "", *table_lines(rows)]
    (out / "results.md").write_text("\n".join(md) + "\n", encoding="utf-8")
    settings = {k: globals()[k] for k in ("DURATION", "COUPLING", "SPIN_UP", "HOLD", "SPEED_LIMIT",
                                          "STEADY_START", "STEADY_TOL", "TE_WINDOW", "REFERENCE_STEP",
                                          "ENERGY_TOL", "UNDAMPED_GAIN")}
    data = {"settings": settings, "seconds": seconds,
            "rows": [{k: _plain(v) for k, v in asdict(r).items()} for r in rows]}
    (out / "results.json").write_text(json.dumps(data, indent=1), encoding="utf-8")


def main(fmu: pathlib.Path, names: list[str] | None, steps: list[str] | None,
         out: pathlib.Path) -> int:
    """`gearmesh stability --trains`; exit 1 if a run fails."""
    selected = cases([n for t in (names or []) for n in t.split(",") if n] or None)
    chosen = parse_steps(steps, False) if steps else list(STEPS)
    start = time.perf_counter()
    rows = run_suite(fmu, selected, chosen)
    seconds = time.perf_counter() - start
    write_outputs(rows, out, seconds)
    print("\n".join(table_lines(rows)))
    print(f"gearmesh: {summary_line(rows, seconds)} {out / 'results.md'}, {out / 'results.json'}")
    return 0 if all(r.passed for r in rows) else 1
