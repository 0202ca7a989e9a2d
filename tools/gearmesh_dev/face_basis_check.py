"""Level 5's reduced face basis against the solve over every slice (docs/model.md, "FE level",
Reduced face basis): on the scenes of the level-5 accuracy ledger, at each of their reference
torques, the loaded TE's mean, peak-to-peak and mesh orders 1-3 with `solver.face_shapes = K`
against `solver.face_shapes = 0`, as relative changes, and per K the largest of them and where.
docs/model.md's table of those largest changes is this command's output:

    gearmesh-dev face-basis-check --shapes 2,3,4

It runs `gearmesh accuracy`'s own sweeps (gearmesh.accuracy.sweep, every pose of the reference's
roll positions, quasi-static, no friction) on the scene FMUs `gearmesh accuracy` makes (the
databases built where missing, as `gearmesh-dev ledger` does); about two minutes per scene and K
once the databases are cached."""
from __future__ import annotations

import argparse
import os
import pathlib
import subprocess
import sys
import tempfile

from gearmesh_dev import checkout
from gearmesh_dev.ledger import LEDGERS

QUANTITIES = ("mean", "pp", "order1", "order2", "order3")


def relative_changes(full: dict, reduced: dict) -> dict[str, float]:
    """Per quantity the change from `full` to `reduced`, relative to |full| (NaN where full is 0)."""
    return {q: (reduced[q] - full[q]) / abs(full[q]) if full[q] != 0 else float("nan")
            for q in QUANTITIES}


def largest(rows: list[dict]) -> dict[int, dict]:
    """Per K the row and quantity of the largest |relative change| (rows as check() yields them)."""
    out: dict[int, dict] = {}
    for row in rows:
        for q in QUANTITIES:
            change = abs(row["changes"][q])
            best = out.get(row["shapes"])
            if change == change and (best is None or change > best["change"]):
                out[row["shapes"]] = {"change": change, "quantity": q, **row}
    return out


def check(scenes: list[pathlib.Path], reference: pathlib.Path, fmu: pathlib.Path, shapes: list[int],
          work: pathlib.Path, progress: bool = True):
    """Yields per scene, torque and K: {'scene', 'torque', 'shapes', 'changes', 'full'}."""
    from gearmesh.accuracy import levels, settings
    from gearmesh.accuracy.sweep import sweep
    from gearmesh.scene import load_scene

    for path in scenes:
        scene = load_scene(path)
        refs = levels.references(scene, reference)
        if not refs:
            raise RuntimeError(f"{path}: no reference in {reference}")
        folder = work / scene.name
        folder.mkdir(parents=True, exist_ok=True)
        notes: list[str] = []
        scene_fmu, plan = levels.scene_fmu(scene, fmu, folder, "level5", notes, build=True, progress=progress)
        torques = sorted({t for r in refs for t in settings.torques("level5", r.torques)})
        n_positions = max(r.n_positions for r in refs)
        for planned in plan:
            full = sweep(scene_fmu, {**planned.values, "solver.face_shapes": 0}, torques, n_positions, repeats=1)
            for k in shapes:
                reduced = sweep(scene_fmu, {**planned.values, "solver.face_shapes": k}, torques, n_positions,
                                repeats=1)
                for t in torques:
                    row = {"scene": scene.name, "torque": t, "shapes": k,
                           "changes": relative_changes(full.summary[t], reduced.summary[t]),
                           "full": full.summary[t]}
                    if progress:
                        print(f"{scene.name:26s} K={k} {t:6.0f} N m  " + "  ".join(
                            f"{q} {100 * v:+.4f} %" for q, v in row["changes"].items()), file=sys.stderr, flush=True)
                    yield row


def table(rows: list[dict]) -> str:
    """The largest change per K as docs/model.md's markdown table, headed by commit and machine."""
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=checkout(), capture_output=True,
                                text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        commit = "(not a git checkout)"
    lines = [f"commit {commit}, {os.cpu_count()} cores", "", "| K | largest change | where |", "|---|---|---|"]
    for k, best in sorted(largest(rows).items()):
        name = {"mean": "mean", "pp": "p-p"}.get(best["quantity"], f"order {best['quantity'][-1]}")
        lines.append(f"| {k} | {100 * best['change']:.3g} % ({name}) | {best['scene']}, {best['torque']:g} N·m |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    from gearmesh.accuracy.report import provenance

    repo = checkout()
    parser = argparse.ArgumentParser(prog="gearmesh-dev face-basis-check", description=__doc__.split("\n\n")[0])
    parser.add_argument("scenes", nargs="*", type=pathlib.Path,
                        help="scene files (default: the level-5 accuracy ledger's)")
    parser.add_argument("--shapes", default="3", help="comma-separated K to compare with K = 0, each 1..8 "
                        "(default: 3)")
    parser.add_argument("--fmu", type=pathlib.Path, default=repo / "build" / "GearMesh.fmu",
                        help="the generic FMU the scene FMUs are made from")
    parser.add_argument("--work", type=pathlib.Path, help="the scene FMUs (default: a temporary folder)")
    args = parser.parse_args(argv)
    try:
        shapes = [int(k) for k in args.shapes.split(",")]
    except ValueError:
        parser.error(f"--shapes {args.shapes!r}: comma-separated integers 1..8")
    if not shapes or any(not 1 <= k <= 8 for k in shapes):
        parser.error(f"--shapes {args.shapes!r}: each K in 1..8")
    made = provenance(LEDGERS[1])
    scenes = args.scenes or [repo / s for s in made["scenes"]]
    with tempfile.TemporaryDirectory() as tmp:
        rows = list(check(scenes, repo / made["reference"], args.fmu, shapes, args.work or pathlib.Path(tmp)))
    print(table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
