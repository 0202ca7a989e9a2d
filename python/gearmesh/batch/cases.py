"""A batch's cases (docs/batch.md): scenes x load cases x parameter variations, and one case's run
(a loaded TE sweep of the scene's FMU), in a worker or in this process."""
from __future__ import annotations

import itertools
import math
import pathlib
import tempfile
from dataclasses import dataclass

from gearmesh.fmu_driver import GearMeshFMU
from gearmesh.main_job import RUN_DEFAULTS
from gearmesh.prescribed_motion import loaded_te_sweep
from gearmesh.scene import Scene
from gearmesh.scene_fmu import build_scene_fmu

OBSERVATIONS = ("gear1_phi_rad", "te_m", "normal_force_N", "pairs_in_contact", "friction_power_W")


@dataclass(frozen=True)
class Case:
    scene: Scene
    torque: float                           # N m on gear 2
    overrides: tuple[tuple[str, float], ...]  # FMU parameter or input -> SI value
    tags: tuple[tuple[str, object], ...] = ()  # extra columns, not FMU variables (a study's case)


def expand(scenes: list[Scene], torques: list[float] | None,
           variations: dict[str, list[float]]) -> list[Case]:
    """The cases: every scene x torque (the scene's own run.torques_Nm unless given) x every
    combination of the parameter variations. Level 5's databases are not built here: the batch
    builds them as tasks (batch_tasks), run_in_process before its cases."""
    names = sorted(variations)
    combos = list(itertools.product(*(variations[n] for n in names))) or [()]
    cases = []
    for scene in scenes:
        run = {**RUN_DEFAULTS, **scene.run}
        for torque in torques or run["torques_Nm"]:
            for combo in combos:
                cases.append(Case(scene, float(torque), tuple(zip(names, combo))))
    return cases


def run_case(case: Case, generic_fmu: str) -> list[dict]:
    """One case (in a worker, or in this process): tidy rows, one per roll angle. The scene's
    resources are local files (level 5: its databases among them)."""
    scene = case.scene
    run = {**RUN_DEFAULTS, **scene.run}
    with tempfile.TemporaryDirectory() as tmp:
        fmu_path = build_scene_fmu(pathlib.Path(generic_fmu), scene.parameters, scene.resources,
                                   pathlib.Path(tmp) / f"{scene.name}.fmu")
        params = {"model.quasi_static": True, **dict(case.overrides)}
        with GearMeshFMU(fmu_path, params, instance_name=scene.name) as fmu:
            out = loaded_te_sweep(fmu, [case.torque], run["speed_rpm"], run["te_pitches"],
                                  run["points_per_pitch"])
    base = {"scene": scene.name, "torque_Nm": case.torque, **dict(case.tags), **dict(case.overrides)}
    return [{**base, "gear1_phi_rad": phi, "te_m": te, "normal_force_N": f,
             "pairs_in_contact": int(p), "friction_power_W": w}
            for phi, te, f, p, w in zip(out["gear1.phi"], out["mesh.te"],
                                        out["mesh.normal_force"], out["mesh.pairs_in_contact"],
                                        out["mesh.friction_power"])]


def parse_variation(text: str) -> tuple[str, list[float]]:
    """'model.friction_coefficient=0.3,0.35,0.4' -> (name, values)."""
    name, _, values = text.partition("=")
    if not name or not values:
        raise ValueError(f"--vary {text!r}: expected NAME=V1,V2,...")
    try:
        parsed = [float(v) for v in values.split(",")]
    except ValueError:
        raise ValueError(f"--vary {text!r}: the values must be numbers (SI units)") from None
    if not all(math.isfinite(v) for v in parsed):
        raise ValueError(f"--vary {text!r}: the values must be finite")
    return name, parsed
