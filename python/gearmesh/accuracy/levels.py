"""`gearmesh accuracy`: the error of every setting (stiffness level, slices, coupled teeth, level
5's FE variants) against the FE references of scenarios/reference/ (reference_fe/README.md: the
2-D band of whole gears and the 3-D sectors), with its cost per evaluation measured in the same
run and, at level 5, what its databases cost to build. Writes accuracy.md, accuracy.csv and
accuracy_pareto.png to the output folder (docs/validation.md)."""
from __future__ import annotations

import pathlib
import sys
from dataclasses import dataclass

from tqdm import tqdm

from gearmesh import compliance
from gearmesh.accuracy import iso as accuracy_iso, report as accuracy_report, settings as accuracy_settings
from gearmesh.accuracy.reference import (KINDS, Reference, ReferenceError, curve_error, errors,
                                         lineload_path, pair_errors, pairs_path, peak_line_load_error,
                                         positions_path, read_lineload, read_pairs, read_positions,
                                         read_sector, read_summary, sector_path, summary_path,
                                         WHOLE_SUFFIX, with_sector_correction)
from gearmesh.accuracy.sweep import sweep
from gearmesh.accuracy.timing import round_trip
from gearmesh.paths import Paths
from gearmesh.scene import Scene
from gearmesh.scene_fmu import build_scene_fmu

TABLE = "accuracy_iso_stiffness.txt"  # level 1's table inside the scene FMU's resources/
# Start values replaced per setting (a stiffness table or database at another level is refused).
_PER_SETTING = ("model.stiffness", "model.slices", "model.coupled_teeth", "model.user_stiffness",
                "model.stiffness_table", "gear1.compliance", "gear2.compliance",
                "model.quasi_static", "model.friction_coefficient")


def default_reference_dir(scene: Scene) -> pathlib.Path:
    return scene.path.parent / "reference"


@dataclass(frozen=True)
class Planned:
    """One setting of a scene's plan: its start values, and at level 5 its databases' cost."""
    setting: accuracy_settings.Setting
    values: dict
    database: accuracy_settings.DatabaseCost | None = None


def level5_databases(scene: Scene, generic_fmu: pathlib.Path, notes: list[str],
                     build: bool, progress: bool,
                     preset: str = "full") -> dict[tuple, dict[int, pathlib.Path]]:
    """(coupled teeth, FE variant or None) -> both gears' cached databases: full: every
    coupled-teeth value at the scene's [fe], and every FE variant at the scene's coupled teeth;
    level5: the scene's coupled teeth at its [fe]. build: make what is missing first
    (compliance_tool through gearmesh.compliance; full builds for 3 coupled teeth, which serves
    0-3; level5 for the scene's own, so that its numbers do not depend on what else is cached)."""
    own = accuracy_settings.scene_coupled(scene)
    if preset == "level5":
        wanted = [(own, None)]
    else:
        wanted = [(c, None) for c in accuracy_settings.COUPLED]
        wanted += [(own, v) for v in accuracy_settings.FE_VARIANTS]
    if build and preset == "level5":
        compliance.build_databases(accuracy_settings.level5_scene(scene, own), progress=progress)
    elif build:
        for fe in (None, *accuracy_settings.FE_VARIANTS):
            coupled = max(accuracy_settings.COUPLED) if fe is None else own
            compliance.build_databases(accuracy_settings.level5_scene(scene, coupled, fe),
                                       progress=progress)
    found = {}
    for c, fe in wanted:
        dbs = accuracy_settings.cached_databases(scene, c, generic_fmu, fe=fe)
        if dbs:
            found[(c, fe)] = dbs
    missing = [f"coupled teeth {c}" if fe is None else f"{fe}" for c, fe in wanted
               if (c, fe) not in found]
    if missing:
        notes.append(f"{scene.name}: level 5 skipped for {', '.join(missing)}: no cached "
                     f"compliance databases (`gearmesh accuracy --build-databases` builds them: "
                     f"about 11 s and 1 GiB per gear at the default mesh, 1 min and 5.2 GiB "
                     f"for mesh-fine)")
    return found


def scene_fmu(scene: Scene, generic_fmu: pathlib.Path, folder: pathlib.Path, preset: str,
              notes: list[str], build: bool = False, progress: bool = False):
    """The scene's FMU with level 1's table and the cached level-5 databases as resources, and
    its plan: per setting the start values that select it. Returns (fmu path, [Planned])."""
    base = {k: v for k, v in scene.parameters.items() if k not in _PER_SETTING}
    resources = dict(scene.resources)
    try:
        iso = accuracy_iso.iso_stiffness(generic_fmu, base)
    except accuracy_iso.NotApplicable as exc:
        iso = None
        notes.append(f"{scene.name}: levels 0 and 1 skipped: {exc}")
    else:
        table = accuracy_iso.write_table(iso, folder / f"{scene.name}.{TABLE}")
        resources[TABLE] = table
        notes.append(f"{scene.name}: level 0 at c_gamma_alpha = {iso.c_gamma_alpha / 1e9:.4g} "
                     f"N/(mm µm) (L0(c_ga)) or c' (L0(c')), level 1 with the level-2 curve "
                     f"({table.name}; c' = {iso.c_prime / 1e9:.4g} N/(mm µm), eps_alpha = "
                     f"{iso.contact_ratio:.4g})")
    dbs = (level5_databases(scene, generic_fmu, notes, build, progress, preset)
           if preset in ("full", "level5") else {})
    for paths in dbs.values():
        for path in paths.values():
            resources[f"accuracy_{path.stem[:16]}.gcdb"] = path
    fmu = build_scene_fmu(generic_fmu, base, resources, folder / f"{scene.name}.accuracy.fmu")
    coupled = tuple(c for c, fe in dbs if fe is None)
    variants = tuple(fe for c, fe in dbs if fe is not None)
    plan = []
    for s in accuracy_settings.settings(preset, coupled, variants,
                                        accuracy_settings.scene_coupled(scene)):
        if iso is None and s.level in (0, 1):
            continue
        values, cost = s.parameters(), None
        if s.level == 0:
            values["model.user_stiffness"] = (iso.c_gamma_alpha if s.constant == "c_ga"
                                              else iso.c_prime)
        elif s.level == 1:
            values["model.stiffness_table"] = TABLE
        elif s.level == 5:
            paths = dbs[(s.coupled, s.fe)]
            for i, path in paths.items():
                values[f"gear{i}.compliance"] = f"accuracy_{path.stem[:16]}.gcdb"
            cost = accuracy_settings.database_cost(paths)
        plan.append(Planned(s, values, cost))
    return fmu, plan


def references(scene: Scene, reference_dir: pathlib.Path | None) -> list[Reference]:
    """The scene's 2-D and 3-D references that exist in the folder."""
    folder = reference_dir or default_reference_dir(scene)
    found = []
    for kind in KINDS:
        path = summary_path(folder, scene.name, kind)
        if path.is_file():
            reference = read_summary(path)
            if reference.scene != scene.name:
                raise ReferenceError(f"{path}: rows of scene {reference.scene!r}, not "
                                     f"{scene.name!r}")
            if kind == "3d" and not reference.models[0].endswith(WHOLE_SUFFIX):
                reference = with_sector_correction(reference,
                                                   read_sector(sector_path(folder, scene.name)))
            found.append(reference)
    return found


def compare(scene: Scene, reference: Reference, fmu: pathlib.Path, plan: list, preset: str,
            round_trip_s: float, repeats: int, progress: bool) -> list[dict]:
    """The rows of every setting of the plan against one reference."""
    torques = accuracy_settings.torques(preset, reference.torques)
    curves = read_positions(positions_path(reference.path.parent, scene.name, reference.kind),
                            reference.n_positions)
    if reference.mean_correction:   # the sector bias is a body compliance: alike at every position
        curves = {key: [te + reference.mean_correction[key[1]][0] for te in values]
                  for key, values in curves.items()}
    shares, loads = (read_pairs(pairs_path(reference.path.parent, scene.name),
                                reference.n_positions) if reference.kind == "2d" else ({}, {}))
    peaks = (read_lineload(lineload_path(reference.path.parent, scene.name), reference.n_positions)
             if reference.kind == "3d" else {})
    rows = []
    for planned in tqdm(plan, desc=f"{scene.name} ({reference.label})", disable=not progress,
                        leave=False):
        setting, db = planned.setting, planned.database
        result = sweep(fmu, planned.values, torques, reference.n_positions, repeats)
        cost = {"plain_us": (result.plain_step - round_trip_s) * 1e6,
                "plain_raw_us": result.plain_step * 1e6,
                "quasi_static_us": (result.qs_step - round_trip_s) * 1e6,
                "quasi_static_raw_us": result.qs_step * 1e6, "round_trip_us": round_trip_s * 1e6,
                "fe_variant": setting.fe or "",
                "db_build_s": db.build_s if db else "", "db_peak_MiB": db.peak_MiB if db else ""}
        for torque in torques:
            curve = curve_error(curves, torque, result.te[torque], reference.models)
            pairs = pair_errors(shares, loads, torque, result.load_share[torque],
                                result.pair_line_load[torque], reference.models)
            peak = peak_line_load_error(peaks, torque, setting.slices, result.max_line_load[torque])
            for e in (errors(reference, torque, result.summary[torque])
                      + ([curve] if curve else []) + pairs + ([peak] if peak else [])):
                rows.append({"scene": scene.name, "reference": reference.label,
                             "setting": setting.label, "level": setting.level,
                             "slices": setting.slices,
                             "coupled_teeth": "" if setting.coupled is None else setting.coupled,
                             "torque_Nm": torque, **e, **cost})
    return rows


def run(scenes: list[Scene], generic_fmu: pathlib.Path, out: pathlib.Path,
        reference_dir: pathlib.Path | None, preset: str, repeats: int = 2,
        progress: bool = True, build: bool = False) -> tuple[list[dict], list[str]]:
    """The tidy rows (accuracy_report.COLUMNS) of every scene with a reference (2-D, 3-D or
    both), and the notes. build: make level 5's missing databases first (full, level5)."""
    notes: list[str] = []
    rows: list[dict] = []
    base = round_trip(generic_fmu)
    notes.append(f"bare fmpy round trip (fmi2DoStep without contact work): {base * 1e6:.1f} µs")
    for scene in scenes:
        found = references(scene, reference_dir)
        if not found:
            folder = reference_dir or default_reference_dir(scene)
            notes.append(f"{scene.name}: skipped, no reference summary "
                         f"{summary_path(folder, scene.name).name} or "
                         f"{summary_path(folder, scene.name, '3d').name} in {folder}")
            continue
        folder = out / scene.name
        folder.mkdir(parents=True, exist_ok=True)
        fmu, plan = scene_fmu(scene, generic_fmu, folder, preset, notes, build, progress)
        for reference in found:
            rows += compare(scene, reference, fmu, plan, preset, base, repeats, progress)
    return rows, notes


def main(scenes: list[Scene], generic_fmu: pathlib.Path, out: pathlib.Path,
         reference_dir: pathlib.Path | None, preset: str, tolerance: float,
         build: bool = False) -> int:
    out.mkdir(parents=True, exist_ok=True)
    rows, notes = run(scenes, generic_fmu, out, reference_dir, preset, build=build)
    for n in notes:
        print(f"gearmesh accuracy: {n}", file=sys.stderr)
    if not rows:
        print("gearmesh accuracy: no scene has a reference summary; nothing compared",
              file=sys.stderr)
        return 1
    entries = accuracy_report.per_setting(rows)
    first = accuracy_report.header([s.path for s in scenes],
                                   reference_dir or default_reference_dir(scenes[0]), preset,
                                   Paths.resolve().checkout or pathlib.Path.cwd())
    csv_path = accuracy_report.write_csv(out / "accuracy.csv", rows, first)
    md_path = out / "accuracy.md"
    md_path.write_text(accuracy_report.markdown(entries, tolerance, notes))
    png = accuracy_report.plot(out / "accuracy_pareto.png", entries)
    for scene, kind in dict.fromkeys((e["scene"], e["reference"]) for e in entries):
        best = accuracy_report.cheapest_within(
            [e for e in entries if (e["scene"], e["reference"]) == (scene, kind)], tolerance)
        print(f"{scene} ({kind} reference): cheapest within {100 * tolerance:g} %: "
              + (f"{best['setting']} ({100 * best['score']:.1f} %, {best['plain_us']:.1f} µs "
                 "plain)" if best else "none"))
    print(f"gearmesh accuracy: {md_path}, {csv_path}, {png}")
    return 0
