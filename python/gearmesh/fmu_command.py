"""`gearmesh fmu SCENE.toml`: the scene's FMU, listing only what the scene uses
(gearmesh.scene_interface; docs/fmi.md, "Scene interfaces")."""
from __future__ import annotations

import pathlib
import zipfile
from collections import Counter
from collections.abc import Iterable

from gearmesh import main_levels
from gearmesh.levels import Level
from gearmesh.param_ranges import parameter_use
from gearmesh.scene import Scene
from gearmesh.scene_fmu import array_variables, build_scene_fmu, model_variables
from gearmesh.scene_interface import MODE_PARAMETERS, default_interface, listed_variables


def write_scene_fmu(scene: Scene, generic_fmu: pathlib.Path, out: pathlib.Path,
                    interface: str | None = None, tunable: Iterable[str] = ()) -> tuple[str, set[str]]:
    """Write the scene FMU at `out` with `interface` (default: the scene's [fmu] interface, else
    the one its mounting calls for); returns the interface and the names it lists. At level 5
    the compliance databases are built (cached) and shipped; at other levels no database is."""
    level = scene.level
    if level == Level.FE:
        scene = main_levels.scene_at_level(scene, 5)
    mode = scene.fmu.get("mode")
    fixed = {**scene.parameters, **(MODE_PARAMETERS[mode] if mode else {})}
    interface = interface or scene.fmu.get("interface") or default_interface(fixed, scene.bearing_motion)
    listed = listed_variables(causalities(generic_fmu), fixed, interface, [*scene.fmu.get("tunable", []), *tunable],
                              scene.fmu.get("outputs", []), arrays=set(offered_arrays(generic_fmu)),
                              use=parameter_use(generic_fmu))
    build_scene_fmu(generic_fmu, fixed, scene.resources, out, listed)
    return interface, listed


def causalities(fmu: pathlib.Path) -> dict[str, str]:
    """name -> causality of every variable the FMU lists and of every array it offers."""
    with zipfile.ZipFile(fmu) as z:
        xml = z.read("modelDescription.xml").decode()
    return {**{name: v[1] for name, v in model_variables(xml).items()},
            **{name: a.causality for name, a in array_variables(xml).items()}}


def offered_arrays(fmu: pathlib.Path) -> list[str]:
    """The arrays the FMU offers (FMI 3.0 array variables; FMI 2.0: its annotation's)."""
    with zipfile.ZipFile(fmu) as z:
        return list(array_variables(z.read("modelDescription.xml").decode()))


def summary(interface: str, listed: set[str], generic_fmu: pathlib.Path, out: pathlib.Path) -> str:
    """One line: where, which interface, how many variables of each causality."""
    variables = causalities(generic_fmu)
    counts = Counter(variables[n] for n in listed)
    parts = ", ".join(f"{counts[c]} {c}s" for c in ("input", "output", "parameter", "calculatedParameter"))
    return f"{out}: {interface} interface, {parts}"
