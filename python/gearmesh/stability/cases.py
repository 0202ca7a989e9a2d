"""The stiff and extreme cases of `gearmesh stability` (docs/stability.md).

Every case is the paper's set A (57/57, m_n 2.6 mm, b 23 mm, the FMU defaults) on two rigid gear
inertias J1 = J2 = 0.02 kg m^2 unless it changes that, with:
* a speed-driven gear 1: a shaft (2e4 N m/rad, 10 N m s/rad) to a far end turning at the case's
  speed, pre-twisted by the drive torque, so that the run starts in the quasi-static equilibrium;
* the load on gear 2 as an external torque (`load`, N m, + loads flank A);
* mesh damping 1e5 N s/m^2 (about 5 % of critical on the mesh mode), so that what the start
  excites dies out within the run; the damping cases set 0 and the maximum.
The cases at 10 rpm are judged against the converged dynamics (te_check).
"""
from __future__ import annotations

import math
import pathlib
from dataclasses import dataclass, field
from typing import Callable

from gearmesh.gear_pair import GearPair, Shaft, constant
from gearmesh.paths import Paths



def _scene_file(name: str) -> pathlib.Path:
    """A file of the scenes folder (the checkout's scenarios/, or $GEARMESH_SCENES)."""
    return (Paths.resolve().scenes or pathlib.Path("scenarios")) / name
RPM = 2 * math.pi / 60
SLOW = 10.0                    # rpm of the TE cases
NOMINAL = 200.0                # N m on gear 2
SHAFT_K, SHAFT_C = 2.0e4, 10.0
# The suite sets each case's mesh damping itself (model.damping): the large-step mode's default
# dynamics.mesh_damping_ratio would add to it, and the undamped cases must be undamped.
BASE = {"model.damping": 4.0e5, "dynamics.mesh_damping_ratio": 0.0}
SLOW_END = 0.12                # s: a mesh period of set A at 10 rpm (0.105 s) after a settling
FAST_END = 0.02                # s
SETTLE = 0.01                  # s left out of the TE judgement


@dataclass
class Geometry:
    """What a case's setup needs from the FMU (read from the plain element)."""
    r_b1: float
    r_b2: float
    sign: int                  # +1 external, -1 internal
    backlash: float
    base_pitch: float
    tight: float               # tight-mesh centre distance (the FMU's geometry.tight_center_distance)
    centre: float              # the pair's centre distance
    face: float
    k_pair: float              # level 0: stiffness of one tooth pair on the line of action

    @property
    def ratio(self) -> float:
        """omega2 / omega1 of conjugate motion."""
        return -self.sign * self.r_b1 / self.r_b2

    def phi2(self, te: float, phi1: float) -> float:
        return (te - self.r_b1 * phi1) / (self.sign * self.r_b2)

    def load_torque2(self, load: float) -> float:
        """gear2.torque (+phi2) of a load that resists the flank-A drive."""
        return load * self.sign


@dataclass
class Case:
    name: str
    what: str
    params: dict = field(default_factory=dict)      # FMU parameters (beyond BASE)
    inputs: dict = field(default_factory=dict)      # held pose inputs: value or f(Geometry)
    speed_rpm: float = SLOW                         # gear 1's far end (0: no drive shaft)
    load: float | Callable[[Geometry], float] = NOMINAL  # N m on gear 2, + loads flank A
    te0: float | str = "static"                     # initial TE (m) or the quasi-static one
    t_end: float = SLOW_END
    te_check: bool = True                           # judge the TE against the reference
    J: tuple = (0.02, 0.02)
    pair: Callable[["Case", Geometry, float], GearPair] | None = None  # custom setup
    flanks: tuple = ()                              # mesh.flank values the run must show
    contact: bool = True                            # False: the run must never touch
    loaded: bool = True                             # False: contact without load
    random_steps: bool = False
    rollback: bool = False
    resources: dict = field(default_factory=dict)   # resource name -> file (scene FMU)
    fe_scene: str = ""                              # level 5: scene text whose databases to build
    quick: bool = False                             # in the CI subset
    reference_step: float = 0.0                     # s, the TE reference's step (0: the default)
    modes: tuple = ()                               # the modes the case runs in (empty: all)
    undamped: bool = False                          # judged by the undamped rules (gearmesh.stability)
    rattles: bool = False                           # undamped and rattling by its physics: the
                                                    # oscillation may grow; energy judged only
    # pair.center_distance = the tight-mesh distance of the case's gears (the FMU's
    # geometry.tight_center_distance, read at params' pair.center_distance, any that meshes) + this, m
    above_tight: float | None = None


def driven_pair(case: Case, geo: Geometry, te0: float) -> GearPair:
    """Speed source on gear 1 through a pre-twisted shaft, load torque on gear 2, conjugate
    speeds, TE te0."""
    w1 = case.speed_rpm * RPM
    drive = case.load * geo.r_b1 / geo.r_b2 if case.load else 0.0
    k, c = shaft_for(case)
    shaft = Shaft(k, c, phi0=drive / k, omega=w1) if case.speed_rpm else Shaft()
    return GearPair(J1=case.J[0], J2=case.J[1], torque2=constant(geo.load_torque2(case.load)),
                    shaft1=shaft, x0=(0.0, w1, geo.phi2(te0, 0.0), geo.ratio * w1))


def shaft_for(case: Case) -> tuple[float, float]:
    """The drive shaft, scaled with gear 1's inertia so that its mode stays at about 1000
    rad/s (2e4 N m/rad, 10 N m s/rad on 0.02 kg m^2)."""
    scale = case.J[0] / 0.02
    return SHAFT_K * scale, SHAFT_C * scale


def rattle_pair(case: Case, geo: Geometry, te0: float) -> GearPair:
    """Gear 1 driven by an oscillating torque (50 N m at 20 Hz), gear 2 free: it is thrown
    through the backlash and hit on both flanks."""
    return GearPair(J1=case.J[0], J2=case.J[1],
                    torque1=lambda t: 50.0 * math.sin(2 * math.pi * 20.0 * t), x0=(0.0, 0.0, geo.phi2(0.0, 0.0), 0.0))


def reversal_pair(case: Case, geo: Geometry, te0: float) -> GearPair:
    """Speed-driven gear 1 at 10 rpm, the load on gear 2 reversing as 200 cos(2 pi 20 t) N m."""
    w1 = case.speed_rpm * RPM
    return GearPair(J1=case.J[0], J2=case.J[1],
                    torque2=lambda t: geo.load_torque2(NOMINAL * math.cos(2 * math.pi * 20 * t)),
                    shaft1=Shaft(SHAFT_K, SHAFT_C, phi0=NOMINAL * geo.r_b1 / geo.r_b2 / SHAFT_K,
                                 omega=w1),
                    x0=(0.0, w1, geo.phi2(te0, 0.0), geo.ratio * w1))


def separated_pair(case: Case, geo: Geometry, te0: float) -> GearPair:
    """Gear 1 at 1000 rpm on its drive shaft, gear 2 at rest mid-backlash: the first impact
    brings gear 2 up to speed."""
    w1 = case.speed_rpm * RPM
    return GearPair(J1=case.J[0], J2=case.J[1], torque2=constant(geo.load_torque2(case.load)),
                    shaft1=Shaft(SHAFT_K, SHAFT_C, omega=w1),
                    x0=(0.0, w1, geo.phi2(-geo.backlash / 2, 0.0), 0.0))


def free_pair(case: Case, geo: Geometry, te0: float) -> GearPair:
    """No drive, no load: conjugate speeds of 100 rpm mid-backlash, never touching."""
    w1 = 100 * RPM
    return GearPair(J1=case.J[0], J2=case.J[1],
                    x0=(0.0, w1, geo.phi2(-geo.backlash / 2, 0.0), geo.ratio * w1))


def balanced_pair(case: Case, geo: Geometry, te0: float) -> GearPair:
    """Free gears (no shafts) at conjugate speeds, TE te0, under a constant drive torque on gear 1
    and the load it balances on gear 2: what the start excites in the mesh mode stays there, with
    nothing in the system to damp it but the integrator."""
    w1 = case.speed_rpm * RPM
    return GearPair(J1=case.J[0], J2=case.J[1], torque1=constant(case.load * geo.r_b1 / geo.r_b2),
                    torque2=constant(geo.load_torque2(case.load)),
                    x0=(0.0, w1, geo.phi2(te0, 0.0), geo.ratio * w1))


def scaled(m_n: float) -> dict:
    """Set A scaled to another module: lengths with m_n (inertia with m_n^5, load with m_n^3
    are set by the case)."""
    s = m_n / 0.0026
    return {"pair.normal_module": m_n, "pair.center_distance": 0.150 * s,
            "gear1.face_width": 0.023 * s, "gear2.face_width": 0.023 * s}


SMALL_FE_SCENE = """[scene]
name = "stability_small_fe"
description = "Small spur pair for the level-5 stability case (coarse FE mesh, seconds to build)."
[pair]
center_distance_mm = 40.0
normal_module_mm = 2.0
pressure_angle_deg = 20.0
[gear1]
teeth = 20
profile_shift = 0.0
face_width_mm = 10.0
thickness_allowance_um = -20
[gear1.body]
bore_diameter_mm = 10.0
[gear2]
teeth = 20
profile_shift = 0.0
face_width_mm = 10.0
thickness_allowance_um = -20
[gear2.body]
bore_diameter_mm = 10.0
[model]
stiffness_level = 5
slices = 3
coupled_teeth = 1
[fe]
profile_elements = 3
width_elements = 2
fillet_elements = 2
body_size_mm = 6.0
"""


def all_cases() -> list[Case]:
    helix = math.radians(44.9)
    mu = lambda m, v0: {"model.friction_coefficient": m, "model.friction_velocity": v0}
    level = lambda n, **p: {"model.stiffness": n, "model.slices": 5, **p}
    cases = [
        Case("zero_load_contact", "no load, gear 2 pushed along in contact at 10 rpm", load=0.0,
             te0=0.0, loaded=False, quick=True),
        Case("free_in_backlash", "no drive or load, conjugate 100 rpm mid-backlash", load=0.0,
             speed_rpm=0.0, t_end=FAST_END, te_check=False, contact=False, pair=free_pair,
             quick=True),
        Case("nominal", "200 N m at 10 rpm", quick=True),
        Case("load_100x", "20 kN m at 10 rpm (TE about 0.5 mm)", load=100 * NOMINAL),
        Case("load_detection_limit", "the load whose single-pair approach is 0.7 of the "
             "detection range (a quarter base pitch)",
             load=lambda g: 0.7 * 0.25 * g.base_pitch * g.k_pair * g.r_b2),
        Case("load_reversal", "200 N m reversing at 20 Hz through the backlash, 10 rpm",
             t_end=0.1, te_check=False, pair=reversal_pair, flanks=(1, 2)),
        Case("rattle", "50 N m at 20 Hz on gear 1, gear 2 free: both flanks hit",
             speed_rpm=0.0, load=0.0, t_end=0.1, te_check=False, pair=rattle_pair,
             flanks=(1, 2), quick=True),
        Case("separated_1000rpm", "gear 1 at 1000 rpm hits gear 2 at rest from mid-backlash, "
             "20 N m load", speed_rpm=1000.0, load=20.0, t_end=FAST_END, te_check=False,
             pair=separated_pair, quick=True),
        Case("wedging_10um", "gear 2's centre 10 um below the tight-mesh distance: both flanks "
             "loaded", inputs={"gear2.ux": lambda g: g.tight - g.centre - 10e-6}),
        Case("wedging_0.5mm", "gear 2's centre 0.5 mm below the tight-mesh distance",
             inputs={"gear2.ux": lambda g: g.tight - g.centre - 0.5e-3},
             # the TE snaps through ~170 um at tooth events: the reference's p-p at the samples
             # settles only below 5e-7 s (docs/stability.md, "Measured")
             reference_step=2.5e-7),
        Case("tilt_20mrad", "gear 2 tilted by 20 mrad about x (the detection's bound), 10 "
             "slices", params={"model.slices": 10}, inputs={"gear2.rx": 0.02}),
        Case("axial_overlap_0.1mm", "gear 2 offset axially to 0.1 mm of face overlap, 5 N m",
             params={"gear2.axial_offset": 0.0229}, load=5.0),
        Case("mu0_v0_1mm_s", "mu 0, v0 1 mm/s", params=mu(0.0, 1e-3)),
        Case("mu0_v0_0.01mm_s", "mu 0, v0 0.01 mm/s", params=mu(0.0, 1e-5)),
        Case("mu0.5_v0_1mm_s", "mu 0.5, v0 1 mm/s", params=mu(0.5, 1e-3), quick=True),
        Case("mu0.5_v0_0.01mm_s", "mu 0.5, v0 0.01 mm/s", params=mu(0.5, 1e-5)),
        Case("damping_0", "no mesh damping", params={"model.damping": 0.0}),
        Case("damping_max", "mesh damping 1e9 N s/m^2 (the largest allowed)",
             params={"model.damping": 1.0e9}),
        Case("speed_10000rpm", "200 N m at 10 000 rpm (mesh frequency 9.5 kHz)",
             speed_rpm=10000.0, t_end=0.01, te_check=False),
        Case("module_0.2mm", "set A scaled to m_n 0.2 mm (J with m^5, load with m^3)",
             params=scaled(0.0002), J=(0.02 * (0.2 / 2.6) ** 5,) * 2,
             load=NOMINAL * (0.2 / 2.6) ** 3),
        Case("module_20mm", "set A scaled to m_n 20 mm (J with m^5, load with m^3)",
             params=scaled(0.02), J=(0.02 * (20 / 2.6) ** 5,) * 2, load=NOMINAL * (20 / 2.6) ** 3),
        Case("pinion_z6", "z 6 pinion (x 0.5, tip 22.8 mm) with the 57-tooth gear, 20 N m",
             params={"gear1.teeth": 6, "gear1.profile_shift": 0.5, "gear1.tip_diameter": 0.0228,
                     "gear2.profile_shift": 0.0, "pair.center_distance": 0.0835},
             above_tight=40e-6, J=(1e-4, 0.02), load=20.0),
        Case("ring_difference_5", "internal pair 30/35 (the smallest tooth-count difference "
             "allowed), m 2 mm, 20 N m",
             params={"pair.internal": True, "gear1.teeth": 30, "gear2.teeth": 35,
                     "gear1.profile_shift": 0.0, "gear2.profile_shift": 0.0,
                     "pair.normal_module": 0.002, "pair.center_distance": 0.00498},
             J=(0.005, 0.01), load=20.0),
        Case("helix_44.9deg", "helix angle 44.9 deg, 10 slices",
             params={"pair.helix_angle": helix, "model.slices": 10, "pair.center_distance": 0.2115},
             above_tight=40e-6),
        Case("level_0", "stiffness level 0 (user constant), 5 slices", params=level(0)),
        Case("level_1", "stiffness level 1 (user table: scenarios/user_stiffness_example.txt)",
             params=level(1, **{"model.stiffness_table": "stiffness.txt"}),
             resources={"stiffness.txt": _scene_file("user_stiffness_example.txt")}),
        Case("level_2", "stiffness level 2 (ISO 6336-1 method B)", params=level(2)),
        Case("level_3", "stiffness level 3 (contact-line length)", params=level(3)),
        Case("level_4", "stiffness level 4 (analytical + Hertz)", params=level(4), quick=True),
        Case("level_5", "stiffness level 5 (FE databases of a small 20/20 pair, m 2 mm, b 10 mm"
             ", coarse mesh), 20 N m", load=20.0, fe_scene=SMALL_FE_SCENE, J=(5e-4, 5e-4)),
        Case("undamped_10rpm", "no mesh damping, free gears at 10 rpm under balanced 150 N m, "
             "teeth just touching at the start, 2 s", params={"model.damping": 0.0}, load=150.0,
             te0=0.0, t_end=2.0, te_check=False, pair=balanced_pair, modes=("large_step",),
             undamped=True, quick=True),
        Case("undamped_10rpm_level_4", "undamped_10rpm at stiffness level 4, 10 slices",
             params={"model.damping": 0.0, "model.stiffness": 4, "model.slices": 10}, load=150.0,
             te0=0.0, t_end=2.0, te_check=False, pair=balanced_pair, modes=("large_step",),
             undamped=True),
        Case("undamped_10rpm_level_5", "undamped_10rpm at stiffness level 5 (level_5's small 20/20 "
             "pair and databases), 20 N m", params={"model.damping": 0.0}, load=20.0, te0=0.0, t_end=2.0,
             te_check=False, pair=balanced_pair, modes=("large_step",), undamped=True,
             fe_scene=SMALL_FE_SCENE, J=(5e-4, 5e-4)),
        Case("undamped_10rpm_mu0.4", "undamped_10rpm at level 4, 10 slices, with friction mu 0.4 "
             "(v0 0.01 mm/s): friction is the only loss", params={"model.damping": 0.0,
             "model.stiffness": 4, "model.slices": 10, "model.friction_coefficient": 0.4,
             "model.friction_velocity": 1e-5}, load=150.0, te0=0.0, t_end=2.0, te_check=False,
             pair=balanced_pair, modes=("large_step",), undamped=True),
        # At speed the undamped mesh rattles through the backlash, excited parametrically by the
        # changing number of tooth pairs; an independent explicit integration of the element
        # rattles alike (docs/stability.md, "Undamped mesh"): judged by the energy made only.
        Case("undamped_1000rpm_level_4", "undamped free gears at 1000 rpm, level 4, 10 slices, "
             "balanced 150 N m, teeth just touching at the start, 2 s: rattles",
             params={"model.damping": 0.0, "model.stiffness": 4, "model.slices": 10}, load=150.0,
             speed_rpm=1000.0, te0=0.0, t_end=2.0, te_check=False, pair=balanced_pair,
             modes=("large_step",), undamped=True, rattles=True),
        Case("undamped_6000rpm_level_4", "undamped_1000rpm_level_4 at 6000 rpm",
             params={"model.damping": 0.0, "model.stiffness": 4, "model.slices": 10}, load=150.0,
             speed_rpm=6000.0, te0=0.0, t_end=2.0, te_check=False, pair=balanced_pair,
             modes=("large_step",), undamped=True, rattles=True),
        Case("random_steps", "nominal with communication steps drawn log-uniformly in "
             "[h/10, h]", random_steps=True),
        Case("rollback", "nominal; at mid-run the master saves the FMU state, runs on, restores "
             "it and runs again: both continuations must agree", rollback=True, quick=True),
    ]
    return cases


def select(names: list[str] | None, quick: bool = False) -> list[Case]:
    """The cases by name (all if None), or the CI subset; an unknown name is an error naming
    the known ones."""
    cases = all_cases()
    if quick and not names:
        return [c for c in cases if c.quick]
    if not names:
        return cases
    known = {c.name: c for c in cases}
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(f"--cases: unknown case(s) {', '.join(unknown)}; known: "
                         f"{', '.join(known)}")
    return [known[n] for n in names]
