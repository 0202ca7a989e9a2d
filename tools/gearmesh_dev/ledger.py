"""The accuracy ledgers: accuracy.csv files of `gearmesh accuracy` kept in the repository, whose
first line records how each was made (the scenes, the reference folder and the preset,
repository-relative), with a `reason` column. CI recomputes them and fails when a signed error
leaves its band: the committed error +- MARGIN (docs/validation.md, "The accuracy ledgers (CI)").

Regenerating (`gearmesh-dev ledger LEDGER [--reason TEXT]`) recomputes the ledger
and refuses to write it when an error moves by more than NEEDS_REASON unless a reason is given;
the reason is then written into each row that moved. Only the errors are gated; the times are
those of the run that wrote the ledger."""
from __future__ import annotations

import argparse
import math
import pathlib
import sys
import tempfile

from gearmesh.accuracy.report import COLUMNS, ERROR_COLUMNS, provenance, read_csv, write_csv
from gearmesh_dev import checkout

REPO = checkout()
# The band of every committed signed error e (each error column of each row): [e - MARGIN,
# e + MARGIN]. Recomputing the ledgers moves their errors by at most 2e-5 percentage points
# (between FMU builds, compliance_tool builds and thread counts of the databases; the test's
# module doc), so the margin is run-to-run noise x 5000 and still catches a sign flip of any
# error above 0.1 point, and a TE 1.05 times as large.
MARGIN = 0.001  # 0.1 percentage point
NEEDS_REASON = 0.01  # 1 percentage point: a regeneration that moves an error more needs a reason
LEDGER_COLUMNS = [*COLUMNS, "reason"]
LEDGERS = (REPO / "scenarios" / "reference" / "ledger_small.csv",
           REPO / "scenarios" / "reference" / "ledger_level5.csv")
def _key(row: dict) -> tuple:
    return (row["scene"], row.get("reference") or "2d", row["setting"], float(row["torque_Nm"]),
            row["quantity"])


def _pp(value: float) -> str:
    return f"{100 * value:+.2f} %"


def _errors(committed: list[dict], new: list[dict]):
    """(key, column, committed error, new error) of every committed error (NaN where `new`
    lacks it; a committed NaN is a column of the other reference kind, skipped), and the keys of
    the committed rows `new` lacks."""
    fresh = {_key(r): r for r in new}
    pairs, lacking = [], []
    for row in committed:
        key = _key(row)
        if key not in fresh:
            lacking.append(key)
            continue
        for column in ERROR_COLUMNS:
            old = float(row[column])
            if not math.isnan(old):
                pairs.append((key, column, old, float(fresh[key].get(column, math.nan))))
    return pairs, lacking


def compare(committed: list[dict], new: list[dict], margin: float = MARGIN) -> list[str]:
    """The gate: every committed signed error (band and each model, each row) that `new` puts
    outside [committed - margin, committed + margin], and every committed row `new` lacks."""
    pairs, lacking = _errors(committed, new)
    problems = [f"{key}: in the ledger, not recomputed" for key in lacking]
    for key, column, old, now in pairs:
        if not abs(now - old) <= margin:
            problems.append(f"{key} {column}: {_pp(now)}, outside its band "
                            f"[{_pp(old - margin)}, {_pp(old + margin)}] (ledger {_pp(old)})")
    return problems


def moves(committed: list[dict], new: list[dict], limit: float = NEEDS_REASON) -> dict[tuple, list[str]]:
    """Row key -> what moved by more than `limit` from the committed ledger to `new` (a committed
    row `new` lacks moved too)."""
    pairs, lacking = _errors(committed, new)
    out: dict[tuple, list[str]] = {key: ["not recomputed"] for key in lacking}
    for key, column, old, now in pairs:
        if not abs(now - old) <= limit:
            out.setdefault(key, []).append(f"{column} {_pp(old)} -> {_pp(now)}")
    return out


class Refused(Exception):
    """A regeneration that moves errors by more than NEEDS_REASON, without a reason."""


def with_reasons(committed: list[dict], new: list[dict], reason: str | None) -> list[dict]:
    """`new` with a `reason` per row: `reason` where an error moved by more than NEEDS_REASON
    (or the row is new), the committed row's own where it did not. Raises Refused naming what
    moved when something did and `reason` is empty."""
    moved = moves(committed, new)
    reason = (reason or "").strip()
    if moved and not reason:
        lines = [f"{key}: {'; '.join(what)}" for key, what in moved.items()]
        raise Refused(f"{len(moved)} row(s) move by more than {100 * NEEDS_REASON:g} percentage "
                      "point; give the reason (--reason), it is written into those rows:\n"
                      + "\n".join(lines))
    old = {_key(r): r.get("reason") or "" for r in committed}
    return [{**row, "reason": reason if (_key(row) in moved or _key(row) not in old)
             else old[_key(row)]} for row in new]


def recompute(ledger: pathlib.Path, fmu: pathlib.Path, out: pathlib.Path,
              progress: bool = False) -> list[dict]:
    """The ledger's rows made again from the inputs its first line names (level 5's databases
    built where missing)."""
    from gearmesh.accuracy import levels as accuracy
    from gearmesh.scene import load_scene

    made = provenance(ledger)
    scenes = [load_scene(REPO / s) for s in made["scenes"]]
    rows, notes = accuracy.run(scenes, fmu, out, REPO / made["reference"], made["settings"],
                               progress=progress, build=True)
    if progress:
        for n in notes:
            print(f"gearmesh accuracy: {n}", file=sys.stderr)
    return rows


def regenerate(ledger: pathlib.Path, new: list[dict], reason: str | None) -> pathlib.Path:
    """Write `new` over the ledger (its first line kept), reasons per with_reasons."""
    first = provenance(ledger)["first_line"]
    rows = with_reasons(read_csv(ledger), new, reason)
    return write_csv(ledger, rows, first, LEDGER_COLUMNS)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="gearmesh-dev ledger",
        description="recompute an accuracy ledger: check it against its bands (--check) or write "
                    "it again (an error that moves by more than 1 percentage point needs --reason)")
    parser.add_argument("ledgers", nargs="*", type=pathlib.Path,
                        help="ledger files (default: the committed ones)")
    parser.add_argument("--reason", help="why the errors moved; written into the rows that moved")
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 naming the "
                        "errors outside their bands")
    parser.add_argument("--fmu", type=pathlib.Path, default=REPO / "build" / "GearMesh.fmu")
    args = parser.parse_args(argv)
    status = 0
    for ledger in args.ledgers or LEDGERS:
        with tempfile.TemporaryDirectory() as tmp:
            new = recompute(ledger, args.fmu, pathlib.Path(tmp), progress=True)
        committed = read_csv(ledger)
        if args.check:
            problems = compare(committed, new)
            print(f"{ledger.name}: " + ("every error inside its band" if not problems else
                                        f"{len(problems)} error(s) outside their bands:"))
            for p in problems:
                print(f"  {p}")
            status |= bool(problems)
            continue
        try:
            regenerate(ledger, new, args.reason)
        except Refused as exc:
            print(f"{ledger.name}: not written: {exc}", file=sys.stderr)
            status = 1
            continue
        print(f"{ledger.name}: written ({len(moves(committed, new))} row(s) moved by more than "
              f"{100 * NEEDS_REASON:g} point)")
    return status


if __name__ == "__main__":
    raise SystemExit(main())
