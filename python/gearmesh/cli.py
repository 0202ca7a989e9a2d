"""Command line: `gearmesh main` runs the main job on scenes into an output folder; a thin layer over
the library (`import gearmesh`). Where files come from: gearmesh.paths."""
from __future__ import annotations

import argparse
import pathlib
import sys

from gearmesh.paths import NotFound, Paths
from gearmesh.scene import SceneError, load_scene

# the default scenes and trains of main, batch and reference, in the scenes folder (gearmesh.paths:
# a checkout's scenarios/, or $GEARMESH_SCENES)
DEFAULT_SCENES = ["paper_setA_3U4U.toml", "paper_setB_P1P2.toml"]
DEFAULT_TRAINS = ["trains/planetary_3_planets.toml"]
FMU_HELP = "the generic FMU (default: $GEARMESH_FMU, else the installed package's, else a checkout's build/)"
OUTPUT = "the output folder: $GEARMESH_OUTPUT, else output/ of the checkout or the working directory"


def _out_help(folder: str = "") -> str:
    return f"default: {folder + '/ in ' if folder else ''}{OUTPUT}"

# subcommands that parse their own options (the rest of the command line): name -> the module
# whose main(argv) does; gearmesh-dev reference-docs documents their options from that parser
DELEGATED: dict[str, str] = {}


def build_parser() -> argparse.ArgumentParser:
    """The `gearmesh` parser with every subcommand (docs/reference/commands.md is generated
    from it by gearmesh-dev reference-docs)."""
    parser = argparse.ArgumentParser(prog="gearmesh", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    p_main = sub.add_parser("main", help="run the main job on scenes (default: the paper's sets)")
    p_main.add_argument("scenes", nargs="*", type=pathlib.Path,
                        help="scene files (TOML; default: the paper's sets A and B and a planetary train "
                        "from the scenes folder, gearmesh.paths)")
    p_main.add_argument("--fmu", type=pathlib.Path, help=FMU_HELP)
    p_main.add_argument("--out", type=pathlib.Path, help=_out_help())
    p_check = sub.add_parser("check", help="validate scene files (against the ranges the FMU "
                             "declares)")
    p_check.add_argument("scenes", nargs="+", type=pathlib.Path)
    p_check.add_argument("--fmu", type=pathlib.Path, help=FMU_HELP)
    p_batch = sub.add_parser("batch", help="scenes x torques x parameter variations in parallel")
    p_batch.add_argument("scenes", nargs="*", type=pathlib.Path, help="scene files (default: the paper's sets A and B)")
    p_batch.add_argument("--fmu", type=pathlib.Path, help=FMU_HELP)
    p_batch.add_argument("--out", type=pathlib.Path, help=_out_help("batch"))
    p_batch.add_argument("--torques", type=float, nargs="+", help="N m (default: each scene's)")
    p_batch.add_argument("--vary", action="append", default=[],
                         help="FMU parameter and SI values, e.g. model.friction_coefficient=0.3,0.4")
    _cluster_options(p_batch)
    p_study = sub.add_parser("study", help="a sampled study (tolerances, misalignment, pitch "
                             "deviations) of one scene on the batch's cluster (docs/batch.md)")
    p_study.add_argument("scenes", nargs=1, type=pathlib.Path, metavar="SCENE.toml")
    p_study.add_argument("--sample", action="append", default=[], required=True,
                         help="NAME=normal(MEAN,SD UNIT) or NAME=uniform(LO,HI UNIT), e.g. "
                         "gear2.rx=normal(0,0.3mrad) or gear1.pitch_A=normal(0,2um)")
    p_study.add_argument("--cases", type=int, required=True, help="samples (1..100000)")
    p_study.add_argument("--seed", type=int, default=0, help="seed of numpy's random generator "
                         "(recorded in study.json; default 0)")
    p_study.add_argument("--torques", type=float, nargs="+", help="N m (default: the scene's)")
    p_study.add_argument("--worst", type=int, default=10, help="worst cases listed (default 10)")
    p_study.add_argument("--fmu", type=pathlib.Path, help=FMU_HELP)
    p_study.add_argument("--out", type=pathlib.Path, help=_out_help("study"))
    _cluster_options(p_study)
    p_ref = sub.add_parser("reference", help="compare the scenes' loaded TE with their reference "
                           "curves, or (--write) regenerate them on purpose")
    p_ref.add_argument("scenes", nargs="*", type=pathlib.Path,
                       help="scene files (default: every scene in the scenes folder with a reference curve)")
    p_ref.add_argument("--fmu", type=pathlib.Path, help=FMU_HELP)
    p_ref.add_argument("--write", action="store_true", help="overwrite the reference curves")
    p_comp = sub.add_parser("compliance", help="build the scenes' compliance databases (FE "
                            "level) into the cache, or copy them out with --out")
    p_comp.add_argument("scenes", nargs="+", type=pathlib.Path)
    p_comp.add_argument("--gear", type=int, choices=(1, 2), help="only this gear")
    p_comp.add_argument("--out", type=pathlib.Path, help="folder to copy <scene>.gear<i>.gcdb to")
    p_comp.add_argument("--tool", type=pathlib.Path, help="compliance_tool binary")
    p_comp.add_argument("--threads", type=int, default=1, help="threads of the tool (1..256)")
    p_comp.add_argument("--force", action="store_true", help="rebuild even if cached")
    p_stab = sub.add_parser("stability", help="stiff and extreme cases x modes x communication "
                            "steps, judged (docs/stability.md)")
    p_stab.add_argument("--fmu", type=pathlib.Path, help=FMU_HELP)
    p_stab.add_argument("--cases", nargs="+", help="case names (default: all; --quick: the CI "
                        "subset)")
    p_stab.add_argument("--modes", nargs="+", help="explicit, implicit, large_step, "
                        "large_step_chain (default: all)")
    p_stab.add_argument("--steps", nargs="+", help="communication steps in s, 1e-7..0.1 "
                        "(default 1e-6 1e-5 1e-4 1e-3 1e-2; --quick: 1e-5 1e-3 1e-2)")
    p_stab.add_argument("--out", type=pathlib.Path, help=_out_help("stability"))
    p_stab.add_argument("--quick", action="store_true", help="the CI subset")
    p_stab.add_argument("--trains", action="store_true", help="the gear-train cases instead "
                        "(gearmesh.stability.trains: each train scene damped and undamped under an "
                        "explicit master; --cases: scene names, optionally :damped or :undamped; "
                        "--steps default 1e-3 1e-2; writes results.md and results.json)")
    p_fmu = sub.add_parser("fmu", help="write a scene's FMU listing only what the scene uses "
                           "(interfaces torsional, planar, full; docs/fmi.md); a train scene's: as train-fmu")
    p_fmu.add_argument("scenes", nargs=1, type=pathlib.Path, metavar="SCENE", help="scene file (TOML)")
    p_fmu.add_argument("--interface", choices=("torsional", "planar", "full"),
                       help="default: the scene's [fmu] interface, else torsional unless it is "
                       "misaligned (full) or its bearings move (planar)")
    p_fmu.add_argument("--tunable", action="append", default=[], metavar="PARAMETER",
                       help="a parameter the scene sets that stays listed and tunable (repeatable)")
    p_fmu.add_argument("--fmi3", action="store_true",
                       help="an FMI 3.0 FMU, from the generic GearMesh-fmi3.fmu (default: FMI 2.0)")
    p_fmu.add_argument("--fmu", type=pathlib.Path, default=None,
                       help="the generic FMU (default: the installed package's GearMesh.fmu, with --fmi3 "
                       "GearMesh-fmi3.fmu; gearmesh.paths)")
    p_fmu.add_argument("--out", type=pathlib.Path, help="default: SCENE_NAME.fmu in the output folder")
    p_train = sub.add_parser("train-fmu", help="write a gear train's FMU (bodies, shafts, meshes; "
                             "gearmesh.train_fmu) around the train binary")
    p_train.add_argument("train", type=pathlib.Path, metavar="TRAIN", help="train scene file (TOML)")
    p_train.add_argument("--out", type=pathlib.Path, help="default: TRAIN_NAME.fmu in the output folder")
    p_train.add_argument("--fmu", type=pathlib.Path,
                         help="the generic pair FMU, whose variables the meshes' parameters are "
                         "checked against (default: as the other commands' --fmu)")
    p_train.add_argument("--binaries", type=pathlib.Path, metavar="DIR",
                         help="pack the train binary of each platform in DIR (DIR/linux64/GearTrain.so, "
                         "win64/GearTrain.dll, darwin64/GearTrain.dylib: gearmesh-dev platforms writes "
                         "build-platforms/GearTrain/binaries); default: $GEARMESH_TRAIN_BINARIES, else "
                         "linux64 only ($GEARMESH_TRAIN_BINARY, else the installed package's GearTrain.so, else a "
                         "checkout's build/fmu_src/GearTrain.so)")
    p_train.add_argument("--fmi3", action="store_true",
                         help="an FMI 3.0 train FMU for this platform ($GEARMESH_TRAIN_BINARY3, else the installed "
                         "package's GearTrain3.so, else a checkout's build/fmu_src/GearTrain3.so)")
    p_acc = sub.add_parser("accuracy", help="error of every stiffness setting against the FE "
                           "reference, with its time per evaluation (docs/validation.md)")
    p_acc.add_argument("scenes", nargs="+", type=pathlib.Path, help="scene files (TOML)")
    p_acc.add_argument("--out", type=pathlib.Path, required=True, help="output folder")
    p_acc.add_argument("--fmu", type=pathlib.Path, help=FMU_HELP)
    p_acc.add_argument("--tolerance", default="5%", help="error allowed for the cheapest "
                       "setting, e.g. 5%% or 0.05; (0, 100%%] (default 5%%)")
    p_acc.add_argument("--settings", default="full", choices=("quick", "level5", "full"),
                       help="quick: levels 2-4 at 10 slices, the lowest and highest reference "
                       "torque (a CI ledger); level5: level 5 at 10 slices and the scene's coupled "
                       "teeth and mesh, every reference torque (a CI ledger); full: levels 0-5 x "
                       "slices 1/3/10/20/40 x coupled teeth 0-3, level 5's FE variants (mesh "
                       "coarse/fine, flank grid loaded at 70/50 %%), every reference torque (default)")
    p_acc.add_argument("--build-databases", action="store_true", help="full, level5: build level "
                       "5's missing compliance databases first (cached; about 11 s and 1 GiB per "
                       "gear at the default mesh, 1 min and 5.2 GiB for mesh-fine)")
    p_acc.add_argument("--reference", type=pathlib.Path, help="folder of the "
                       "<scene>.reference_fe.summary.csv (2-D) and <scene>.reference_fe3d.summary.csv "
                       "(3-D) files (default: reference/ next to each scene)")
    return parser


def _train_fmu(scene: pathlib.Path, out: pathlib.Path | None, fmu: pathlib.Path,
               binaries: pathlib.Path | None, fmi3: bool = False) -> int:
    from gearmesh import train_fmu

    try:
        train = train_fmu.load_train(scene)
        written = train_fmu.build_train_fmu(scene, out or Paths.resolve().output / f"{train.name}.fmu", fmu,
                                            binaries_folder=binaries, fmi3=fmi3)
    except (SceneError, OSError, ValueError) as exc:
        print(f"gearmesh: {exc}", file=sys.stderr)
        return 2
    print(f"gearmesh train-fmu: wrote {written}")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args, rest = parser.parse_known_args(argv)
    if rest and args.command not in DELEGATED:  # those parse their own options
        parser.error(f"unrecognized arguments: {' '.join(rest)}")

    try:
        _resolve_paths(args)
    except NotFound as exc:
        print(f"gearmesh: {exc}", file=sys.stderr)
        return 2
    if args.command == "train-fmu":
        return _train_fmu(args.train, args.out, args.fmu, args.binaries, args.fmi3)
    if args.command == "fmu":
        from gearmesh.train_fmu import is_train_scene

        if is_train_scene(args.scenes[0]):  # a train scene: its train FMU (gearmesh train-fmu)
            if args.interface or args.tunable:
                print("gearmesh: --interface and --tunable are for pair scenes; a train FMU lists its "
                      "members' variables (and the outputs its [fmu] outputs names)", file=sys.stderr)
                return 2
            return _train_fmu(args.scenes[0], args.out, args.fmu, None, args.fmi3)
    if args.command == "stability":
        from gearmesh.stability import suite as stability

        try:
            if args.trains:
                if args.modes or args.quick:
                    raise ValueError("--trains: --modes and --quick do not apply to the train cases")
                from gearmesh.stability import trains as stability_trains

                return stability_trains.main(args.fmu, args.cases, args.steps, args.out)
            return stability.main(args.fmu, args.cases, args.modes, args.steps, args.out,
                                  args.quick)
        except ValueError as exc:
            print(f"gearmesh: {exc}", file=sys.stderr)
            return 2
    paths = list(args.scenes)
    trains: list[pathlib.Path] = []
    if args.command == "main":
        # train scenes (a [train] table) get the main job's train section
        from gearmesh.train_fmu import is_train_scene

        trains = [p for p in paths if is_train_scene(p)] if args.scenes else default_scenes(DEFAULT_TRAINS)
        paths = [p for p in paths if p not in trains]
    if not args.scenes:
        try:
            paths = default_scenes(DEFAULT_SCENES) if args.command != "reference" else referenced_scenes()
        except NotFound as exc:
            print(f"gearmesh: {exc}", file=sys.stderr)
            return 2
    try:
        scenes = [load_scene(p, getattr(args, "fmu", None)) for p in paths]
    except (SceneError, OSError) as exc:
        print(f"gearmesh: {exc}", file=sys.stderr)
        return 2
    if args.command == "check":
        for s in scenes:
            print(f"{s.path}: ok ({len(s.parameters)} parameters)")
        return 0
    if args.command == "compliance":
        return _compliance(scenes, args)
    if args.command == "accuracy":
        from gearmesh.accuracy import levels as accuracy, report as accuracy_report

        try:
            tolerance = accuracy_report.parse_tolerance(args.tolerance)
            return accuracy.main(scenes, args.fmu, args.out, args.reference, args.settings,
                                 tolerance, args.build_databases)
        except ValueError as exc:
            print(f"gearmesh: {exc}", file=sys.stderr)
            return 2
    if args.command == "fmu":
        return _scene_fmu(scenes[0], args)
    if args.command in ("batch", "study"):
        return _batch(scenes, args)
    if args.command == "reference":
        from gearmesh import reference_curves as rc

        status = 0
        for s in scenes:
            curves = rc.compute(s, args.fmu)
            if args.write:
                print(f"{rc.write(s, curves)}: written")
                continue
            worst = rc.compare(s, curves)
            ok = worst <= rc.TOLERANCE
            status |= not ok
            print(f"{s.name}: largest TE difference {worst:.3g} m "
                  f"({'ok' if ok else 'BEYOND'} tolerance {rc.TOLERANCE:g} m)")
        return status
    from gearmesh.compliance import ComplianceError
    from gearmesh.main_job import run_main

    try:
        report = run_main(scenes, args.fmu, args.out, trains)
    except (SceneError, FileNotFoundError, ComplianceError) as exc:  # ComplianceError: a level-5 scene, no tool
        print(f"gearmesh: {exc}", file=sys.stderr)
        return 2
    print(f"gearmesh: report written to {report}")
    return 0


# the commands' default output folders, under the output folder (gearmesh.paths)
OUT_FOLDERS = {"main": "", "batch": "batch", "study": "study", "stability": "stability"}


def _resolve_paths(args) -> None:
    """The generic FMU (--fmu, else gearmesh.paths) and the default output folder of the command."""
    if not hasattr(args, "fmu"):
        return
    paths = Paths.resolve(fmu=args.fmu)
    if args.fmu is None and args.command != "check":  # check: the FMU's ranges, or the built-in ones
        args.fmu = paths.require("fmu3" if getattr(args, "fmi3", False) else "fmu")
    if args.command in OUT_FOLDERS and args.out is None:
        args.out = paths.output / OUT_FOLDERS[args.command]


def default_scenes(names: list[str]) -> list[pathlib.Path]:
    """The default scenes in the scenes folder (gearmesh.paths)."""
    folder = Paths.resolve().require("scenes")
    return [folder / n for n in names]


def referenced_scenes() -> list[pathlib.Path]:
    """The scenes in the scenes folder that have a reference TE curve (the CI regression's)."""
    folder = Paths.resolve().require("scenes")
    return sorted(p for p in folder.glob("*.toml") if (folder / f"{p.stem}.reference_te.csv").is_file())


def _scene_fmu(scene, args) -> int:
    from gearmesh import fmu_command
    from gearmesh.compliance import ComplianceError
    from gearmesh.scene_interface import InterfaceError

    out = args.out or Paths.resolve().output / f"{scene.name}.fmu"
    try:
        interface, listed = fmu_command.write_scene_fmu(scene, args.fmu, out, args.interface, args.tunable)
    except (InterfaceError, ComplianceError, ValueError, OSError) as exc:
        print(f"gearmesh: {exc}", file=sys.stderr)
        return 2
    print(fmu_command.summary(interface, listed, args.fmu, out))
    return 0


def _cluster_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scheduler", help="address of a running Dask scheduler, e.g. "
                   "tcp://host:8786 (default: a local cluster of --jobs workers)")
    p.add_argument("--jobs", type=int, help="local workers (default: one per core)")
    p.add_argument("--shared", type=pathlib.Path, help="a folder every worker reads at the same "
                   "path: the FMU, tables and databases are copied there instead of uploaded")


def _batch(scenes, args) -> int:
    """batch and study: the cases on the cluster; 1 if a case failed, 2 on bad input."""
    from gearmesh import compliance
    from gearmesh.batch import run as batch, cluster, study, study_report

    try:
        if args.command == "study":
            plan = study.plan(scenes[0], args.sample, args.cases, args.seed, args.fmu, args.out)
            cases = study.expand(plan, args.torques)
        else:
            variations = dict(batch.parse_variation(v) for v in args.vary)
            if variations:
                from fmpy import read_model_description

                md = read_model_description(str(args.fmu))
                for name in variations:
                    study.variable_unit(name, md, f"--vary {name}")
            cases = batch.expand(scenes, args.torques, variations)
        result = batch.run_batch(cases, args.fmu, args.out, args.jobs, args.scheduler,
                                 args.shared, report=args.command == "batch")
        if args.command == "study":
            print(f"gearmesh: study report {study_report.write(plan, result, args.worst)}")
    except (ValueError, OSError, cluster.ClusterError, compliance.ComplianceError) as exc:
        print(f"gearmesh: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"gearmesh: interrupted; the finished cases are kept in {args.out / 'cases'}, "
              "run the same command again to resume", file=sys.stderr)
        return 130
    print(f"gearmesh: {result.ran} cases run, {result.skipped} finished before (skipped), "
          f"{len(result.errors)} failed: {result.tidy}, {result.summary}")
    for name, error in result.errors.items():
        print(f"gearmesh: failed: {name}: {error}", file=sys.stderr)
    return 1 if result.errors else 0


def _compliance(scenes, args) -> int:
    import shutil

    from gearmesh import compliance

    for s in scenes:
        gears = compliance.needs_build(s)
        if args.gear is not None:
            gears = [g for g in gears if g == args.gear]
        if not gears:
            print(f"{s.name}: nothing to build (level {s.parameters.get('model.stiffness', 0)}, "
                  "or prebuilt compliance_file)")
            continue
        try:
            builds = compliance.build_databases(s, tool=args.tool, gears=gears,
                                                threads=args.threads, force=args.force)
        except compliance.ComplianceError as exc:
            print(f"gearmesh: {exc}", file=sys.stderr)
            return 1
        for i, b in builds.items():
            where = b.path
            if args.out:
                args.out.mkdir(parents=True, exist_ok=True)
                where = shutil.copyfile(b.path, args.out / f"{s.name}.gear{i}.gcdb")
            how = "cached" if b.cached else f"built in {b.seconds:.1f} s"
            extra = (f", {b.summary['nodes']} nodes, peak {b.summary['peak_rss_MiB']} MiB"
                     if "nodes" in b.summary else "")
            print(f"{s.name} gear{i}: {where} ({how}{extra})")
    return 0
