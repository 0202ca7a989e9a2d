"""`gearmesh accuracy`: the error of every setting (stiffness level, slices, coupled teeth) against
the FE references of scenarios/reference/ (reference_fe/README.md: the 2-D band of whole gears
and the 3-D sectors), with its cost per evaluation measured in the same run. Writes accuracy.md, accuracy.csv and accuracy_pareto.png to the output
folder (docs/validation.md)."""
from __future__ import annotations

import pathlib
import sys

from tqdm import tqdm

from gearmesh import accuracy_iso, accuracy_ledger, accuracy_report, accuracy_settings
from gearmesh.accuracy_reference import (KINDS, Reference, ReferenceError, curve_error, errors,
                                         pair_errors, pairs_path, positions_path, read_pairs,
                                         read_positions, read_summary, summary_path)
from gearmesh.accuracy_sweep import sweep
from gearmesh.accuracy_timing import round_trip
from gearmesh.scene import Scene
from gearmesh.scene_fmu import build_scene_fmu

REPO = pathlib.Path(__file__).resolve().parents[2]
TABLE = "accuracy_iso_stiffness.txt"  # level 1's table inside the scene FMU's resources/
# Start values replaced per setting (a stiffness table or database at another level is refused).
_PER_SETTING = ("model.stiffness", "model.slices", "model.coupled_teeth", "model.user_stiffness",
                "model.stiffness_table", "gear1.compliance", "gear2.compliance",
                "model.quasi_static", "model.friction_coefficient")


def default_reference_dir(scene: Scene) -> pathlib.Path:
    return scene.path.parent / "reference"


def scene_fmu(scene: Scene, generic_fmu: pathlib.Path, folder: pathlib.Path, preset: str,
              notes: list[str]):
    """The scene's FMU with level 1's table and the cached level-5 databases as resources, and
    per setting the start values that select it. Returns (fmu path, [(Setting, values)])."""
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
    coupled_dbs = {}
    if preset == "full":
        for c in accuracy_settings.COUPLED:
            dbs = accuracy_settings.cached_databases(scene, c, generic_fmu)
            if dbs:
                coupled_dbs[c] = dbs
                for i, path in dbs.items():
                    resources[f"accuracy_{path.stem[:16]}.gcdb"] = path
        missing = [c for c in accuracy_settings.COUPLED if c not in coupled_dbs]
        if missing:
            notes.append(f"{scene.name}: level 5 skipped for coupled teeth "
                         f"{', '.join(map(str, missing))}: no cached compliance databases "
                         f"(build them with `python -m gearmesh compliance` on the scene at "
                         f"stiffness_level = 5, coupled_teeth = 3)")
    fmu = build_scene_fmu(generic_fmu, base, resources, folder / f"{scene.name}.accuracy.fmu")
    plan = []
    for s in accuracy_settings.settings(preset, tuple(coupled_dbs)):
        if iso is None and s.level in (0, 1):
            continue
        values = s.parameters()
        if s.level == 0:
            values["model.user_stiffness"] = (iso.c_gamma_alpha if s.constant == "c_ga"
                                              else iso.c_prime)
        elif s.level == 1:
            values["model.stiffness_table"] = TABLE
        elif s.level == 5:
            for i, path in coupled_dbs[s.coupled].items():
                values[f"gear{i}.compliance"] = f"accuracy_{path.stem[:16]}.gcdb"
        plan.append((s, values))
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
            found.append(reference)
    return found


def compare(scene: Scene, reference: Reference, fmu: pathlib.Path, plan: list, preset: str,
            round_trip_s: float, repeats: int, progress: bool) -> list[dict]:
    """The rows of every setting of the plan against one reference."""
    torques = accuracy_settings.torques(preset, reference.torques)
    curves = read_positions(positions_path(reference.path.parent, scene.name, reference.kind),
                            reference.n_positions)
    shares, loads = (read_pairs(pairs_path(reference.path.parent, scene.name),
                                reference.n_positions) if reference.kind == "2d" else ({}, {}))
    rows = []
    for setting, values in tqdm(plan, desc=f"{scene.name} ({reference.kind})",
                                disable=not progress, leave=False):
        result = sweep(fmu, values, torques, reference.n_positions, repeats)
        cost = {"plain_us": (result.plain_step - round_trip_s) * 1e6,
                "plain_raw_us": result.plain_step * 1e6,
                "quasi_static_us": (result.qs_step - round_trip_s) * 1e6,
                "quasi_static_raw_us": result.qs_step * 1e6, "round_trip_us": round_trip_s * 1e6}
        for torque in torques:
            curve = curve_error(curves, torque, result.te[torque], reference.models)
            pairs = pair_errors(shares, loads, torque, result.load_share[torque],
                                result.pair_line_load[torque], reference.models)
            for e in (errors(reference, torque, result.summary[torque])
                      + ([curve] if curve else []) + pairs):
                rows.append({"scene": scene.name, "reference": reference.kind,
                             "setting": setting.label, "level": setting.level,
                             "slices": setting.slices,
                             "coupled_teeth": "" if setting.coupled is None else setting.coupled,
                             "torque_Nm": torque, **e, **cost})
    return rows


def run(scenes: list[Scene], generic_fmu: pathlib.Path, out: pathlib.Path,
        reference_dir: pathlib.Path | None, preset: str, repeats: int = 2,
        progress: bool = True) -> tuple[list[dict], list[str]]:
    """The tidy rows (accuracy_report.COLUMNS) of every scene with a reference (2-D, 3-D or
    both), and the notes."""
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
        fmu, plan = scene_fmu(scene, generic_fmu, folder, preset, notes)
        for reference in found:
            rows += compare(scene, reference, fmu, plan, preset, base, repeats, progress)
    return rows, notes


def main(scenes: list[Scene], generic_fmu: pathlib.Path, out: pathlib.Path,
         reference_dir: pathlib.Path | None, preset: str, tolerance: float) -> int:
    out.mkdir(parents=True, exist_ok=True)
    rows, notes = run(scenes, generic_fmu, out, reference_dir, preset)
    for n in notes:
        print(f"gearmesh accuracy: {n}", file=sys.stderr)
    if not rows:
        print("gearmesh accuracy: no scene has a reference summary; nothing compared",
              file=sys.stderr)
        return 1
    entries = accuracy_report.per_setting(rows)
    first = accuracy_ledger.header([s.path for s in scenes],
                                   reference_dir or default_reference_dir(scenes[0]), preset, REPO)
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
