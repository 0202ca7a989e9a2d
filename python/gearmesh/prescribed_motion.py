"""Quasi-static runs with prescribed spin angles: the FMU as a pure contact element.

TE = r_b1 phi_1 + s r_b2 phi_2 (docs/physics.md §0), so a run that holds TE and turns gear 1 sets
phi_2 = (TE - r_b1 phi_1) / (s r_b2).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

from gearmesh.fmu_driver import GearMeshFMU

OUTPUTS = ["mesh.te", "mesh.normal_force", "mesh.stiffness", "mesh.pairs_in_contact",
           "mesh.flank", "gear1.fx", "gear1.fy", "gear1.mz", "gear2.fx", "gear2.fy", "gear2.mz"]
GEOMETRY = ["geometry.backlash", "geometry.contact_ratio", "geometry.base_pitch",
            "geometry.operating_pressure_angle", "gear1.base_diameter", "gear2.base_diameter"]


@dataclass
class PairKinematics:
    r_b1: float
    r_b2: float
    sign: int  # +1 external, -1 internal

    def phi2(self, te: float, phi1: float) -> float:
        return (te - self.r_b1 * phi1) / (self.sign * self.r_b2)


def pair_kinematics(fmu: GearMeshFMU) -> PairKinematics:
    g = fmu.get(["gear1.base_diameter", "gear2.base_diameter", "pair.internal"])
    return PairKinematics(g["gear1.base_diameter"] / 2, g["gear2.base_diameter"] / 2,
                          -1 if g["pair.internal"] else 1)


def run_poses(fmu: GearMeshFMU, poses, h: float = 1e-3, progress: str | None = None) -> dict:
    """Step through (phi1, phi2) poses; returns output name -> numpy array."""
    rows = {name: [] for name in OUTPUTS}
    for phi1, phi2 in tqdm(poses, desc=progress, disable=progress is None, leave=False):
        fmu.step({"gear1.phi": phi1, "gear2.phi": phi2}, h)
        for name, value in fmu.get(OUTPUTS).items():
            rows[name].append(value)
    return {name: np.asarray(values, dtype=float) for name, values in rows.items()}


def engagement_sweep(fmu: GearMeshFMU, te_from: float, te_to: float, points: int) -> dict:
    """Normal force over TE at phi_1 = 0: backlash on flank B, engagement on flank A."""
    kin = pair_kinematics(fmu)
    tes = np.linspace(te_from, te_to, points)
    return run_poses(fmu, [(0.0, kin.phi2(te, 0.0)) for te in tes])


def revolution_at_approach(fmu: GearMeshFMU, approach: float, points_per_pitch: int,
                           progress: str | None = None) -> dict:
    """One revolution of gear 1 with the TE held at `approach` (rigid-body overlap)."""
    kin = pair_kinematics(fmu)
    z1 = fmu.get(["gear1.teeth"])["gear1.teeth"]
    phi1 = np.arange(z1 * points_per_pitch) * (2 * math.pi / (z1 * points_per_pitch))
    out = run_poses(fmu, [(p, kin.phi2(approach, p)) for p in phi1], progress=progress)
    out["gear1.phi"] = phi1
    return out


def loaded_te_sweep(fmu: GearMeshFMU, torques, omega1: float, pitches: int,
                    points_per_pitch: int, progress: str | None = None) -> dict:
    """Quasi-static loaded TE (the FMU in model.quasi_static mode): for each load torque on gear 2,
    gear 1 turns over `pitches` base pitches at omega1 (the friction direction) and one
    fmi2DoStep per roll angle returns the loaded TE. Tidy columns, one row per (torque, angle)."""
    kin = pair_kinematics(fmu)
    z1 = fmu.get(["gear1.teeth"])["gear1.teeth"]
    angles = np.arange(pitches * points_per_pitch) * (2 * math.pi / (z1 * points_per_pitch))
    names = ["mesh.te", "mesh.normal_force", "mesh.pairs_in_contact", "mesh.friction_power"]
    rows = {"torque": [], "gear1.phi": [], **{n: [] for n in names}}
    omega2 = -kin.sign * omega1 * kin.r_b1 / kin.r_b2
    for torque in tqdm(torques, desc=progress, disable=progress is None, leave=False):
        for phi1 in angles:
            fmu.step({"gear1.phi": phi1, "mesh.load_torque": torque, "gear1.omega": omega1,
                      "gear2.omega": omega2})
            rows["torque"].append(torque)
            rows["gear1.phi"].append(phi1)
            for name, value in fmu.get(names).items():
                rows[name].append(value)
    return {name: np.asarray(values, dtype=float) for name, values in rows.items()}


def mesh_order_amplitudes(te, pitches: int, orders=(1, 2)) -> dict[int, float]:
    """Amplitudes of the mesh orders of a TE sampled uniformly over whole pitches (the n-th mesh
    order is the n-th harmonic of one pitch: order n z1 of a revolution)."""
    spectrum = np.fft.rfft(np.asarray(te, dtype=float))
    return {n: 2 * abs(spectrum[n * pitches]) / len(te) for n in orders}
