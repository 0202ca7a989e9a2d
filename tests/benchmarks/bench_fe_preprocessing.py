"""Benchmark of the FE level's preprocessing and evaluation (prints figures, never gates).

1. compliance_tool on set A's 57-tooth gear at the default mesh (scenarios/fe/paper_setA_3U4U_fe.toml;
   issue 16's targets: <= 15 s wall on 2 cores and <= 1.5 GiB), against a baseline build of a small
   gear (z 20, m 2 mm, b 10 mm, coarse mesh) in the same process: median and spread of the wall
   time from this process, of the tool's CPU time (getrusage of the children: user + system,
   every thread) and of the tool's stage times, its peak RSS and getrusage(RUSAGE_CHILDREN).maxrss. With --baseline-tool OLD the
   same set A build also runs with another compliance_tool binary (e.g. one built from an earlier
   commit), interleaved with this one's, and the ratio of the medians is printed. With --fine,
   one build of set A at the fine mesh (12 x 8 x 4; targets <= 60 s, <= 3 GiB).
   Each build is forced (no cache hit) into a temporary cache that 2. then reuses.
2. One fmi2DoStep of the quasi-static loaded TE at level 5 (set A, the database of 1.) against
   level 4 of the same FMU, in the same process: median and spread over repeats.

    .venv/bin/python tests/benchmarks/bench_fe_preprocessing.py [--repeats N] [--small-only]
        [--baseline-tool OLD_COMPLIANCE_TOOL] [--fine] [--no-fmu]

The machine's load average is printed with the figures (they are noisy on a shared machine).
A failed build is printed.
"""
from __future__ import annotations

import argparse
import math
import os
import pathlib
import resource
import statistics
import sys
import tempfile
import time

from gearmesh import compliance
from gearmesh.fmu_driver import GearMeshFMU
from gearmesh.paths import find_checkout
from gearmesh.scene import load_scene, parse_scene
from gearmesh.scene_fmu import build_scene_fmu

REPO = find_checkout(pathlib.Path(__file__).parent)

SMALL = """
[pair]
center_distance_mm = 40.0
normal_module_mm = 2.0
[gear1]
teeth = 20
profile_shift = 0.0
face_width_mm = 10.0
thickness_allowance_um = -20
[gear2]
teeth = 20
profile_shift = 0.0
face_width_mm = 10.0
thickness_allowance_um = -20
[model]
stiffness_level = 5
slices = 5
[fe]
profile_elements = 3
width_elements = 2
fillet_elements = 2
body_size_mm = 6.0
"""


def spread(values):
    med = statistics.median(values)
    return f"median {med:.3g}, min {min(values):.3g}, max {max(values):.3g} (n = {len(values)})"


def timed_build(scene, cache, gear=1, tool=None):
    """One forced build (no cache hit) into `cache`, which part 2 then reuses."""
    def children_cpu():
        ru = resource.getrusage(resource.RUSAGE_CHILDREN)
        return ru.ru_utime + ru.ru_stime
    cpu0, start = children_cpu(), time.perf_counter()
    b = compliance.build_gear(scene, gear, tool=tool, cache=cache, progress=False, force=True)
    wall = time.perf_counter() - start
    summary = dict(b.summary, cpu_s=children_cpu() - cpu0)  # user + system, every thread
    rss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024  # MiB (Linux: KiB)
    return wall, summary, rss


def load_text():
    return "load average " + " / ".join(f"{x:.2f}" for x in os.getloadavg()) + " (1 / 5 / 15 min)"


def describe(label, runs, targets=""):
    """One line of a set of builds: wall, the tool's CPU time, stages (medians), peak RSS."""
    s = runs[0][1]

    def med(key):
        values = [r[1][key] for r in runs if key in r[1]]
        return f"{statistics.median(values):.2f}" if values else "?"
    peak = max(r[1].get("peak_rss_MiB", 0) for r in runs)
    return (f"{label} ({s.get('nodes')} nodes, {s.get('dofs')} dofs, grid {s.get('grid')}): wall s "
            f"{spread([r[0] for r in runs])}; tool CPU s "
            f"{spread([r[1]['cpu_s'] for r in runs])}; "
            f"stages (median s): mesh {med('mesh_s')}, assembly {med('assembly_s')}, factorization "
            f"{med('factor_s')}, solves {med('solve_s')}; peak RSS {peak:.0f} MiB (tool), "
            f"{runs[-1][2]:.0f} MiB (getrusage: the largest child so far){targets}")


def step_times(fmu_file, overrides, repeats, points=40, torque=200.0):
    """Per-step wall times (s) of the quasi-static loaded TE over one pitch, `repeats` times."""
    per_step = []
    with GearMeshFMU(fmu_file, {"model.quasi_static": True, **overrides}) as fmu:
        z1 = fmu.get(["gear1.teeth"])["gear1.teeth"]
        angles = [i * 2 * math.pi / z1 / points for i in range(points)]
        for _ in range(repeats):
            start = time.perf_counter()
            for phi in angles:
                fmu.step({"gear1.phi": phi, "mesh.load_torque": torque, "gear1.omega": 0.0,
                          "gear2.omega": 0.0})
            per_step.append((time.perf_counter() - start) / points)
    return per_step


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3, help="builds of the 57-tooth gear")
    ap.add_argument("--small-repeats", type=int, default=3)
    ap.add_argument("--small-only", action="store_true")
    ap.add_argument("--baseline-tool", type=pathlib.Path,
                    help="another compliance_tool, run interleaved on set A: the ratio to it")
    ap.add_argument("--fine", action="store_true", help="also one build at the fine mesh 12 x 8 x 4")
    ap.add_argument("--no-fmu", action="store_true", help="the database builds only (no part 2)")
    ap.add_argument("--fmu", type=pathlib.Path, default=REPO / "build" / "GearMesh.fmu")
    args = ap.parse_args()

    tmp = tempfile.TemporaryDirectory()
    cache = pathlib.Path(tmp.name) / "cache"
    print(f"before: {load_text()}")
    small = parse_scene(SMALL, REPO / "small.toml")
    small_runs = [timed_build(small, cache) for _ in range(args.small_repeats)]
    print(describe("small gear (z 20)", small_runs))
    timings = [("small pair z 20/20, 5 slices", small)]
    if not args.small_only:
        set_a_file = REPO / "scenarios" / "fe" / "paper_setA_3U4U_fe.toml"
        set_a = load_scene(set_a_file)
        base_cache = pathlib.Path(tmp.name) / "baseline"
        try:
            big_runs, base_runs = [], []
            for _ in range(args.repeats):
                big_runs.append(timed_build(set_a, cache))
                if args.baseline_tool:
                    base_runs.append(timed_build(set_a, base_cache, tool=args.baseline_tool))
        except compliance.ComplianceError as exc:
            rss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
            print(f"set A gear (z 57, default mesh): FAILED ({exc}); peak RSS {rss:.0f} MiB "
                  "(getrusage, children)")
        else:
            print(describe("set A gear (z 57, default mesh)", big_runs,
                           "; issue 16's targets 15 s, 1536 MiB"))
            ratio = (statistics.median(r[0] for r in big_runs)
                     / statistics.median(r[0] for r in small_runs))
            print(f"ratio set A / small gear build (wall): {ratio:.1f}")
            if base_runs:
                print(describe(f"baseline tool {args.baseline_tool.name}, set A", base_runs))
                for key, pick in (("wall", lambda r: r[0]), ("CPU", lambda r: r[1]["cpu_s"])):
                    new = statistics.median(pick(r) for r in big_runs)
                    old = statistics.median(pick(r) for r in base_runs)
                    print(f"ratio set A this tool / baseline tool ({key}): {new / old:.2f}")
            timings.append(("set A 57/57, 10 slices", set_a))
        if args.fine:
            text = set_a_file.read_text() + ("\n[fe]\nprofile_elements = 12\nwidth_elements = 8\n"
                                             "fillet_elements = 4\n")
            fine = parse_scene(text, set_a_file)
            try:
                fine_runs = [timed_build(fine, pathlib.Path(tmp.name) / "fine")]
            except compliance.ComplianceError as exc:
                print(f"set A gear, fine mesh 12 x 8 x 4: FAILED ({exc})")
            else:
                print(describe("set A gear (z 57, fine mesh 12 x 8 x 4)", fine_runs,
                               "; issue 16's targets 60 s, 3072 MiB"))
    print(f"after the builds: {load_text()}")
    if args.no_fmu:
        tmp.cleanup()
        return 0

    for label, scene in timings:
        with tempfile.TemporaryDirectory() as run_dir:
            full = compliance.with_databases(scene, cache=cache, progress=False)  # cache hits
            fmu_file = build_scene_fmu(args.fmu, full.parameters, full.resources,
                                       pathlib.Path(run_dir) / "fe.fmu")
            no_db = {"gear1.compliance": "", "gear2.compliance": ""}
            torque = 50.0 if scene is small else 200.0
            l5 = step_times(fmu_file, {}, 7, torque=torque)
            l4 = step_times(fmu_file, {"model.stiffness": 4, **no_db}, 7, torque=torque)
        print(f"fmi2DoStep (quasi-static loaded TE, {label}, {torque:g} N m, through fmpy): "
              f"level 5 {spread([t * 1e6 for t in l5])} us, level 4 "
              f"{spread([t * 1e6 for t in l4])} us; ratio "
              f"{statistics.median(l5) / statistics.median(l4):.2f}")
    tmp.cleanup()
    return 0


if __name__ == "__main__":
    sys.exit(main())
