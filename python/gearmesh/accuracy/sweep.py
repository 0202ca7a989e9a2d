"""One setting's loaded TE and cost: the FMU's quasi-static mode over one pitch at the reference's
positions (position k: gear 1 turned by k (2 pi / z1) / n, reference_fe/README.md, "Positions and
TE"), frictionless as the reference, per torque the mean, p-p and mesh orders 1-3; then the same
poses in plain mode (prescribed spins at the solved TE) for the plain evaluation's cost.

A torque here is the reference's: the torque on gear 1 (reference_fe turns gear 1's bore against
gear 2's clamped one). The FMU's mesh.load_torque is gear 2's load, so it is set to
torque * r_b2 / r_b1 (frictionless balance on the line of action), then corrected at each position
until gear 1's contact moment (gear1.mz) is the torque: a tip corner outside the path of contact
pushes along the mate's involute normal, whose arm about gear 1 is not r_b1, so while a corner
carries, gear 2's load and gear 1's torque are not in the ratio of the base radii (set A at
350 N·m: +-0.3 %)."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gearmesh.accuracy.reference import MIN_POSITIONS
from gearmesh.accuracy.timing import StepTimer
from gearmesh.fmu_driver import GearMeshFMU
from gearmesh.prescribed_motion import mesh_order_amplitudes, pair_kinematics

OMEGA1 = 10 * 2 * math.pi / 60  # rad/s: only the friction direction, and there is no friction
# gear 1's torque is held to this share of the torque (a few correction steps at the positions
# where a tip corner carries; the load's effect on gear1.mz is nearly proportional)
TORQUE_TOLERANCE = 1e-7
MAX_CORRECTIONS = 6
_READ = ["mesh.te", "gear1.mz", "mesh.max_load_share", "mesh.normal_force", "mesh.max_line_load"]
_FACES = [f"gear{i}.{n}" for i in (1, 2) for n in ("face_width", "axial_offset")]


@dataclass
class SweepResult:
    te: dict[float, np.ndarray]            # torque (N m) -> TE (m) at the n positions
    summary: dict[float, dict[str, float]]  # torque -> mean, pp, order1..3 (m)
    qs_step: float                         # median s per fmi2DoStep, quasi-static
    plain_step: float                      # median s per fmi2DoStep, plain (prescribed spins)
    qs_calls: int
    plain_calls: int
    gear1_torque: dict[float, np.ndarray]  # torque -> gear1.mz at the positions (N m)
    load_share: dict[float, np.ndarray]    # torque -> mesh.max_load_share at the positions
    # torque -> the most loaded pair's force over the face width at the positions (N/m):
    # mesh.max_load_share x mesh.normal_force / the face widths' overlap
    pair_line_load: dict[float, np.ndarray]
    # torque -> mesh.max_line_load at the positions (N/m): the largest slice's force over the
    # slice width
    max_line_load: dict[float, np.ndarray]


def summarize(te: np.ndarray) -> dict[str, float]:
    orders = mesh_order_amplitudes(te, pitches=1, orders=(1, 2, 3))
    return {"mean": float(np.mean(te)), "pp": float(np.ptp(te)),
            **{f"order{n}": float(a) for n, a in orders.items()}}


def _hold_gear1_torque(fmu: GearMeshFMU, timer: StepTimer, inputs: dict, torque: float,
                       load: float, row: dict) -> tuple[float, dict]:
    """Steps the pose again with gear 2's load corrected until gear 1's torque is `torque`; the
    load and the last reading. The correction steps are left out of the timing (each pose is
    timed once, at its first step, as in plain mode)."""
    timed = len(timer.seconds)
    for corrections in range(MAX_CORRECTIONS + 1):
        moment = abs(row["gear1.mz"])
        if moment == 0 or abs(moment - torque) <= TORQUE_TOLERANCE * torque:
            break
        if corrections == MAX_CORRECTIONS:
            raise RuntimeError(f"gear 1's torque {moment:.9g} N m not held at "
                               f"{torque:g} N m within {TORQUE_TOLERANCE:g} after {MAX_CORRECTIONS} "
                               "corrections of gear 2's load")
        load *= torque / moment
        fmu.step({**inputs, "mesh.load_torque": load})
        row = fmu.get(_READ)
    del timer.seconds[timed:]
    return load, row


def sweep(fmu_path, parameters: dict, torques: list[float], n_positions: int,
          repeats: int = 2) -> SweepResult:
    """`parameters`: FMU start values on top of the FMU's own (the setting's level, slices...).
    The TE is that of the first pass; each further pass repeats the poses for the timing only."""
    if n_positions < MIN_POSITIONS:
        raise ValueError(f"n_positions = {n_positions}; allowed: >= {MIN_POSITIONS} (mesh order 3 "
                         "below the Nyquist order)")
    if repeats < 1:
        raise ValueError(f"repeats = {repeats}; allowed: >= 1")
    common = {**parameters, "model.friction_coefficient": 0.0}
    te: dict[float, np.ndarray] = {}
    gear1_torque: dict[float, np.ndarray] = {}
    load_share: dict[float, np.ndarray] = {}
    pair_line_load: dict[float, np.ndarray] = {}
    max_line_load: dict[float, np.ndarray] = {}
    with GearMeshFMU(fmu_path, {**common, "model.quasi_static": True},
                     instance_name="accuracy_qs") as fmu:
        kin = pair_kinematics(fmu)
        z1 = fmu.get(["gear1.teeth"])["gear1.teeth"]
        angles = np.arange(n_positions) * (2 * math.pi / z1) / n_positions
        omega2 = -kin.sign * OMEGA1 * kin.r_b1 / kin.r_b2
        ratio = kin.r_b2 / kin.r_b1  # gear 2's load torque per unit torque on gear 1
        width = fmu.get(["geometry.face_overlap"])["geometry.face_overlap"]
        timer = StepTimer(fmu)
        loads = {t: [t * ratio] * n_positions for t in torques}
        for rep in range(repeats):
            for torque in torques:
                rows = []
                for k, phi1 in enumerate(angles):
                    inputs = {"gear1.phi": phi1, "gear1.omega": OMEGA1, "gear2.omega": omega2}
                    fmu.step({**inputs, "mesh.load_torque": loads[torque][k]})
                    row = fmu.get(_READ)
                    if rep == 0:
                        loads[torque][k], row = _hold_gear1_torque(fmu, timer, inputs, torque,
                                                                   loads[torque][k], row)
                    rows.append(row)
                if rep == 0:
                    te[torque] = np.array([r["mesh.te"] for r in rows])
                    gear1_torque[torque] = np.array([r["gear1.mz"] for r in rows])
                    load_share[torque] = np.array([r["mesh.max_load_share"] for r in rows])
                    pair_line_load[torque] = np.array(
                        [r["mesh.max_load_share"] * r["mesh.normal_force"] / width for r in rows])
                    max_line_load[torque] = np.array([r["mesh.max_line_load"] for r in rows])
        qs_step, qs_calls = timer.median(), len(timer.seconds)
    with GearMeshFMU(fmu_path, {**common, "model.quasi_static": False},
                     instance_name="accuracy_plain") as fmu:
        timer = StepTimer(fmu)
        for _ in range(repeats):
            for torque in torques:
                for phi1, value in zip(angles, te[torque]):
                    fmu.step({"gear1.phi": phi1, "gear2.phi": kin.phi2(value, phi1)})
        plain_step, plain_calls = timer.median(), len(timer.seconds)
    return SweepResult(te, {t: summarize(v) for t, v in te.items()}, qs_step, plain_step,
                       qs_calls, plain_calls, gear1_torque, load_share, pair_line_load,
                       max_line_load)
