"""`gearmesh-dev COMMAND`: the maintainer tools on a GearMesh checkout (docs/developer/README.md):
the multi-platform FMU, the generated documentation (FMU page, docs/reference/, docs/img/), the
accuracy ledgers, level 4's tooth-coupling fit and level 5's face-basis check."""
from __future__ import annotations

import argparse
import importlib
import pathlib
import sys

# subcommands that parse their own options (the rest of the command line): name -> the module
# whose main(argv) does
DELEGATED = {"platforms": "gearmesh_dev.platforms", "ledger": "gearmesh_dev.ledger",
             "coupling-fit": "gearmesh_dev.coupling_fit", "face-basis-check": "gearmesh_dev.face_basis_check"}


def build_parser() -> argparse.ArgumentParser:
    """The `gearmesh-dev` parser (docs/reference/commands.md is generated from it and the user's
    `gearmesh` parser by gearmesh-dev reference-docs)."""
    parser = argparse.ArgumentParser(prog="gearmesh-dev", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("platforms", add_help=False,
                   help="build the multi-platform FMU (linux64, win64, darwin64) into build-platforms/")
    sub.add_parser("fmu-docs", help="regenerate the FMU's documentation/index.html from README.md "
                   "and docs/fmi.md")
    p_refdocs = sub.add_parser("reference-docs", help="regenerate docs/reference/ (scene keys, FMU "
                               "variables, commands) from the code's tables, the FMU's "
                               "modelDescription.xml and the command parsers")
    p_refdocs.add_argument("--fmu", type=pathlib.Path, help="the generic FMU whose "
                           "modelDescription.xml the pages document (default: $GEARMESH_FMU, "
                           "else build/GearMesh.fmu)")
    p_refdocs.add_argument("--check", action="store_true", help="write nothing; exit 1 naming "
                           "the pages that differ from a fresh generation")
    p_fig = sub.add_parser("figures", help="the user docs' pictures (docs/img/), made from the "
                           "project's own outputs (gearmesh_dev.figures)")
    p_fig.add_argument("--out", type=pathlib.Path, help="default: docs/img")
    p_fig.add_argument("--only", nargs="+", metavar="NAME", help="te_set_a, schematic, pareto, "
                       "stability_map, study_histogram, compliance_mesh (default: all)")
    p_fig.add_argument("--fmu", type=pathlib.Path, help="default: build/GearMesh.fmu")
    p_fig.add_argument("--work", type=pathlib.Path,
                       help="intermediate files: scene FMUs, stability table, study cases, mesh "
                       "(default: output/figures)")
    p_fig.add_argument("--stability-table", type=pathlib.Path, help="draw this `gearmesh "
                       "stability` table.csv instead of running the quick suite (about 1.5 min)")
    p_fig.add_argument("--study-cases", type=int, default=100, help="tolerance study samples")
    p_fig.add_argument("--jobs", type=int, default=1, help="the study's local workers (default 1)")
    sub.add_parser("ledger", add_help=False,
                   help="recompute the accuracy ledgers (scenarios/reference/ledger_*.csv), or --check them")
    sub.add_parser("coupling-fit", add_help=False,
                   help="fit level 4's tooth-coupling table from coarse compliance databases")
    sub.add_parser("face-basis-check", add_help=False,
                   help="level 5's reduced face basis against the solve over every slice on the "
                   "level-5 ledger's scenes")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args, rest = parser.parse_known_args(argv)
    if args.command in DELEGATED:
        return importlib.import_module(DELEGATED[args.command]).main(rest)
    if rest:
        parser.error(f"unrecognized arguments: {' '.join(rest)}")
    try:
        if args.command == "fmu-docs":
            from gearmesh_dev import fmu_docs

            return fmu_docs.main()
        if args.command == "reference-docs":
            from gearmesh_dev import reference_docs

            return reference_docs.main(args.fmu, args.check)
        from gearmesh_dev import figures

        return figures.main(args.out or figures.DEFAULT_OUT, args.only, figures.Options(
            args.fmu or figures.Options.fmu, args.work or figures.DEFAULT_WORK, args.stability_table,
            args.study_cases, args.jobs))
    except RuntimeError as exc:  # outside a checkout
        print(f"gearmesh-dev: {exc}", file=sys.stderr)
        return 2
