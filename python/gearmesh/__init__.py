"""GearMesh: the gear-mesh contact FMU and its Python tooling.

What a script needs (docs/tooling.md, "From Python"):

    import gearmesh

    scene = gearmesh.load_scene("scenarios/paper_setA_3U4U.toml")   # read and check a scene
    fmu = gearmesh.write_scene_fmu(scene, "setA.fmu")                # its FMU, values built in
    te = gearmesh.loaded_te(scene, torques=[100.0, 350.0])            # quasi-static TE sweep
    report = gearmesh.run_main([scene], out="out")                    # the main job's report
    with gearmesh.open_fmu(fmu) as mesh:                              # named variables
        print(mesh.get(["mesh.te"]))

Where the generic FMU, the scenes and the output folder come from: gearmesh.paths (options,
environment variables, the working directory; an installed package carries the FMUs).
"""
from __future__ import annotations

import os
import pathlib
import tempfile
from importlib.metadata import PackageNotFoundError, version

from gearmesh.fmu_driver import FMUError, GearMeshFMU
from gearmesh.paths import NotFound, Paths
from gearmesh.scene import Scene, SceneError, load_scene

try:
    __version__ = version("gearmesh")
except PackageNotFoundError:  # pragma: no cover - imported from a source tree without installing
    __version__ = "0+unknown"

__all__ = ["FMUError", "GearMeshFMU", "NotFound", "Paths", "Scene", "SceneError", "__version__",
           "generic_fmu", "load_scene", "loaded_te", "open_fmu", "resolve_paths", "run_main",
           "write_scene_fmu"]

PathLike = str | os.PathLike


def resolve_paths(**options) -> Paths:
    """The files and folders GearMesh uses (gearmesh.paths.Paths.resolve: fmu=, output=,
    checkout=, ... options; then the environment and the working directory)."""
    return Paths.resolve(**options)


def generic_fmu(fmi3: bool = False) -> pathlib.Path:
    """The generic GearMesh.fmu (fmi3: GearMesh-fmi3.fmu) that scene FMUs are made from."""
    return Paths.resolve().require("fmu3" if fmi3 else "fmu")


def _scene(scene: Scene | PathLike) -> Scene:
    return scene if isinstance(scene, Scene) else load_scene(scene)


def write_scene_fmu(scene: Scene | PathLike, out: PathLike, *, interface: str | None = None,
              tunable: tuple[str, ...] = (), fmi3: bool = False, fmu: PathLike | None = None) -> pathlib.Path:
    """Write the scene's FMU (the generic binary with the scene's start values and resources,
    listing what the interface needs: `gearmesh fmu`) at `out`; returns its path. At level 5
    the compliance databases are built (cached) and shipped."""
    from gearmesh import fmu_command

    out = pathlib.Path(out)
    fmu_command.write_scene_fmu(_scene(scene), pathlib.Path(fmu) if fmu else generic_fmu(fmi3), out, interface, tunable)
    return out


def loaded_te(scene: Scene | PathLike, torques: list[float] | None = None, *, pitches: int | None = None,
              points_per_pitch: int | None = None, fmu: PathLike | None = None) -> dict:
    """Quasi-static loaded TE sweep of the scene: for each load torque on gear 2 (N m; default the
    scene's [run] torques_Nm), gear 1 turned over `pitches` base pitches (default the scene's
    te_pitches, 3). Columns as numpy arrays, one row per (torque, angle): torque, gear1.phi (rad),
    mesh.te (m), mesh.normal_force (N), mesh.pairs_in_contact, mesh.friction_power (W)."""
    import numpy as np

    from gearmesh.compliance import with_databases
    from gearmesh.main_job import RUN_DEFAULTS
    from gearmesh.prescribed_motion import loaded_te_sweep
    from gearmesh.scene_fmu import build_scene_fmu

    scene = with_databases(_scene(scene), progress=False)
    run = {**RUN_DEFAULTS, **scene.run}
    torques = list(torques if torques is not None else run["torques_Nm"])
    if not torques:
        raise ValueError(f"{scene.name}: no torques given and the scene's [run] torques_Nm is empty")
    with tempfile.TemporaryDirectory() as tmp:
        path = build_scene_fmu(pathlib.Path(fmu) if fmu else generic_fmu(), scene.parameters, scene.resources,
                               pathlib.Path(tmp) / f"{scene.name}.fmu")
        with GearMeshFMU(path, {"model.quasi_static": True}, instance_name=scene.name) as mesh:
            out = loaded_te_sweep(mesh, torques, run["speed_rpm"], pitches or run["te_pitches"],
                                  points_per_pitch or run["points_per_pitch"])
    return {k: np.asarray(v) for k, v in out.items()}


def run_main(scenes: list[Scene | PathLike], out: PathLike | None = None, *, trains: list[PathLike] = (),
             fmu: PathLike | None = None) -> pathlib.Path:
    """The main job (`gearmesh main`) on the scenes (and train scenes), into `out` (default the
    output folder of gearmesh.paths); returns the report's path (report.md)."""
    from gearmesh import main_job

    where = Paths.resolve(fmu=fmu, output=out)
    return main_job.run_main([_scene(s) for s in scenes], where.require("fmu"), where.output,
                             [pathlib.Path(t) for t in trains])


def open_fmu(fmu: PathLike, parameters: dict | None = None, **kwargs) -> GearMeshFMU:
    """One instance of a GearMesh FMU (generic or a scene's) with named variables: parameters set
    before initialization, then `set`, `step`, `get` by name; a context manager that frees it."""
    return GearMeshFMU(fmu, parameters, **kwargs)
