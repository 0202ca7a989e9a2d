"""Two rigid gear inertias around the mesh, each with an external torque and an optional shaft
(spring-damper) to a far end whose motion is prescribed: the plant of the stability suite.

    far end 1 ~~ shaft (k1, c1) ~~ gear 1 (J1, torque T1(t)) == GearMesh == gear 2 (J2, T2(t))
        ~~ shaft (k2, c2) ~~ far end 2

The same system is what the FMU's large-step mode (model.dynamics = 1) integrates itself with
the inputs gear<i>.torque, gear<i>.shaft_phi, gear<i>.shaft_omega, so one GearPair describes a
run for every mode of `gearmesh stability`. Torques act in +phi_i; the shaft's torque on gear i is
k_i (phi_far - phi_i) + c_i (omega_far - omega_i). As a plant of gearmesh.drivetrain's masters the
state is (phi1, omega1, phi2, omega2) and the energy balance is closed with the mesh's own
outputs (mesh.elastic_energy, mesh.damping_power, mesh.friction_power):

    work of the torques and far ends = d(kinetic + shaft springs + mesh elastic)
                                       + friction + mesh damping + shaft damping.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

Signal = Callable[[float], float]


def constant(value: float) -> Signal:
    return lambda t: value


@dataclass
class Shaft:
    """A shaft from gear i to a far end moving at phi0 + omega t (+ an optional oscillation
    amplitude * sin(2 pi f t) of the angle)."""
    stiffness: float = 0.0            # N m/rad
    damping: float = 0.0              # N m s/rad
    phi0: float = 0.0                 # rad, far end at t = 0
    omega: float = 0.0                # rad/s
    amplitude: float = 0.0            # rad
    frequency: float = 0.0            # Hz

    def phi(self, t: float) -> float:
        return self.phi0 + self.omega * t + self.amplitude * math.sin(2 * math.pi * self.frequency * t)

    def rate(self, t: float) -> float:
        w = 2 * math.pi * self.frequency
        return self.omega + self.amplitude * w * math.cos(w * t)

    def torque(self, t: float, phi: float, omega: float) -> float:
        """The shaft's torque on the gear."""
        return self.stiffness * (self.phi(t) - phi) + self.damping * (self.rate(t) - omega)


@dataclass
class GearPair:
    """SI. x0 = (phi1, omega1, phi2, omega2) at t = 0."""
    J1: float = 0.02
    J2: float = 0.02
    torque1: Signal = field(default_factory=lambda: constant(0.0))
    torque2: Signal = field(default_factory=lambda: constant(0.0))
    shaft1: Shaft = field(default_factory=Shaft)
    shaft2: Shaft = field(default_factory=Shaft)
    x0: tuple = (0.0, 0.0, 0.0, 0.0)

    @property
    def shafts(self) -> tuple[Shaft, Shaft]:
        return self.shaft1, self.shaft2

    @property
    def torques(self) -> tuple[Signal, Signal]:
        return self.torque1, self.torque2


class GearPairPlant:
    """A GearPair as a plant of gearmesh.drivetrain.Integrator."""

    links = [(0, "gear1.phi"), (1, "gear1.omega"), (2, "gear2.phi"), (3, "gear2.omega")]
    outputs = ["gear1.mz", "gear2.mz"]
    recorded = ["mesh.elastic_energy", "mesh.damping_power", "mesh.flank", "solver.iterations"]
    size = 4
    velocity_rows = [1, 3]
    scale = np.array([1e-6, 1e-3, 1e-6, 1e-3])

    def __init__(self, pair: GearPair):
        self.pair = pair
        self.x0 = np.array(pair.x0, dtype=float)
        self.J = np.array([pair.J1, pair.J2])

    def rhs(self, t: float, x: np.ndarray, m: np.ndarray) -> np.ndarray:
        dx = np.empty(4)
        for i, (shaft, torque) in enumerate(zip(self.pair.shafts, self.pair.torques)):
            phi, w = x[2 * i], x[2 * i + 1]
            dx[2 * i] = w
            dx[2 * i + 1] = (torque(t) + shaft.torque(t, phi, w) + m[i]) / self.J[i]
        return dx

    def jacobian(self, t: float, x: np.ndarray, Jm: np.ndarray) -> np.ndarray:
        A = np.zeros((4, 4))
        for i, shaft in enumerate(self.pair.shafts):
            A[2 * i, 2 * i + 1] = 1
            A[2 * i + 1, 2 * i] = -shaft.stiffness / self.J[i]
            A[2 * i + 1, 2 * i + 1] = -shaft.damping / self.J[i]
            A[2 * i + 1, :] += Jm[i] / self.J[i]
        return A

    def powers(self, t: float, x: np.ndarray, out: dict) -> dict:
        """Work rates of the sources (torques, far ends) and the losses, W."""
        flows = {}
        shaft_damping = 0.0
        for i, (shaft, torque) in enumerate(zip(self.pair.shafts, self.pair.torques)):
            w = x[2 * i + 1]
            flows[f"torque{i + 1}"] = torque(t) * w
            flows[f"far_end{i + 1}"] = shaft.torque(t, x[2 * i], w) * shaft.rate(t)
            shaft_damping += shaft.damping * (shaft.rate(t) - w) ** 2
        flows["shaft_damping"] = shaft_damping
        flows["friction"] = out["mesh.friction_power"]
        flows["mesh_damping"] = out.get("mesh.damping_power", math.nan)  # NaN: FMU lacks it
        return flows

    def stored(self, t: float, x: np.ndarray, out: dict) -> float:
        kinetic = 0.5 * float(self.J @ (x[[1, 3]] ** 2))
        springs = sum(0.5 * s.stiffness * (s.phi(t) - x[2 * i]) ** 2
                      for i, s in enumerate(self.pair.shafts))
        return kinetic + springs + out.get("mesh.elastic_energy", math.nan)

    def balance(self, energy: dict, T: np.ndarray, X: np.ndarray, mesh0: dict,
                mesh_end: dict) -> dict:
        """Residual = work of the sources - stored change - losses; work_in = the initial energy
        plus the positive work of each source (the scale the suite judges the residual by)."""
        e0 = self.stored(T[0], X[0], mesh0)
        e1 = self.stored(T[-1], X[-1], mesh_end)
        sources = [k for k in energy if k.startswith(("torque", "far_end"))]
        losses = energy["friction"] + energy["mesh_damping"] + energy["shaft_damping"]
        energy["stored"] = e1 - e0
        energy["residual"] = sum(energy[k] for k in sources) - (e1 - e0) - losses
        energy["work_in"] = e0 + sum(max(energy[k], 0.0) for k in sources)
        return energy
