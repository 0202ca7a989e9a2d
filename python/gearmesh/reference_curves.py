"""Reference TE curves: each scene keeps its loaded TE curves in scenarios/<scene>.reference_te.csv;
CI recomputes them and fails beyond TOLERANCE. Writing them is a deliberate command
(`gearmesh reference --write SCENE...`) whose commit says why the curves changed."""
from __future__ import annotations

import csv
import pathlib
import tempfile

import numpy as np

from gearmesh.compliance import with_databases
from gearmesh.fmu_driver import GearMeshFMU
from gearmesh.main_job import RUN_DEFAULTS
from gearmesh.prescribed_motion import loaded_te_sweep
from gearmesh.scene import Scene
from gearmesh.scene_fmu import build_scene_fmu

# The computation is deterministic; this bounds what a change of compiler, libm or summation
# order may move, far below anything physical (TE amplitudes are micrometres).
TOLERANCE = 1e-9  # m


def reference_path(scene: Scene) -> pathlib.Path:
    return scene.path.parent / f"{scene.name}.reference_te.csv"


def compute(scene: Scene, generic_fmu: pathlib.Path) -> dict:
    """The scene's loaded TE sweep (its run torques, speed, pitches and points per pitch)."""
    run = {**RUN_DEFAULTS, **scene.run}
    if not run["torques_Nm"]:
        raise ValueError(f"{scene.path}: run.torques_Nm is empty: no reference curve to compute")
    scene = with_databases(scene)  # level 5: the gears' compliance databases as resources
    with tempfile.TemporaryDirectory() as tmp:
        fmu_path = build_scene_fmu(generic_fmu, scene.parameters, scene.resources,
                                   pathlib.Path(tmp) / f"{scene.name}.fmu")
        with GearMeshFMU(fmu_path, {"model.quasi_static": True}, instance_name=scene.name) as fmu:
            return loaded_te_sweep(fmu, run["torques_Nm"], run["speed_rpm"], run["te_pitches"],
                                   run["points_per_pitch"])


def write(scene: Scene, curves: dict) -> pathlib.Path:
    path = reference_path(scene)
    with path.open("w", newline="") as fh:
        fh.write(f"# Reference loaded TE of {scene.path.name}: gearmesh reference "
                 f"--write; regenerate only on purpose and say why in the commit\n")
        writer = csv.writer(fh)
        writer.writerow(["torque_Nm", "gear1_phi_rad", "te_m"])
        for row in zip(curves["torque"], curves["gear1.phi"], curves["mesh.te"]):
            writer.writerow([f"{row[0]:.17g}", f"{row[1]:.17g}", f"{row[2]:.17g}"])
    return path


def read(path: pathlib.Path) -> dict:
    with path.open() as fh:
        rows = list(csv.reader(line for line in fh if not line.startswith("#")))
    header, body = rows[0], np.array(rows[1:], dtype=float)
    return {name: body[:, i] for i, name in enumerate(header)}


def compare(scene: Scene, curves: dict) -> float:
    """Largest |TE - reference| in m; raises if the sweep does not match the reference's grid."""
    ref = read(reference_path(scene))
    if len(ref["te_m"]) != len(curves["mesh.te"]) or not (
            np.array_equal(ref["torque_Nm"], curves["torque"])
            and np.allclose(ref["gear1_phi_rad"], curves["gear1.phi"], rtol=0, atol=1e-15)):
        raise ValueError(f"{reference_path(scene)}: the scene's sweep grid changed; regenerate "
                         "the reference on purpose")
    return float(np.max(np.abs(ref["te_m"] - curves["mesh.te"])))
