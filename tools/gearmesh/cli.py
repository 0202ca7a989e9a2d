"""Command line: `python -m gearmesh main` runs the default scenes into an output folder."""
from __future__ import annotations

import argparse
import pathlib
import sys

from gearmesh.scene import SceneError, load_scene

REPO = pathlib.Path(__file__).resolve().parents[2]
DEFAULT_SCENES = [REPO / "scenarios" / "paper_setA_3U4U.toml",
                  REPO / "scenarios" / "paper_setB_P1P2.toml"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="gearmesh", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    p_main = sub.add_parser("main", help="run the main job on scenes (default: the paper's sets)")
    p_main.add_argument("scenes", nargs="*", type=pathlib.Path, help="scene files (TOML)")
    p_main.add_argument("--fmu", type=pathlib.Path, default=REPO / "build" / "GearMesh.fmu")
    p_main.add_argument("--out", type=pathlib.Path, default=REPO / "output")
    p_check = sub.add_parser("check", help="validate scene files")
    p_check.add_argument("scenes", nargs="+", type=pathlib.Path)
    args = parser.parse_args(argv)

    try:
        scenes = [load_scene(p) for p in (args.scenes or DEFAULT_SCENES)]
    except (SceneError, OSError) as exc:
        print(f"gearmesh: {exc}", file=sys.stderr)
        return 2
    if args.command == "check":
        for s in scenes:
            print(f"{s.path}: ok ({len(s.parameters)} parameters)")
        return 0
    from gearmesh.main_job import run_main

    report = run_main(scenes, args.fmu, args.out)
    print(f"gearmesh: report written to {report}")
    return 0
