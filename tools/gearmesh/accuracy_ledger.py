"""The accuracy ledger: an accuracy.csv of `gearmesh accuracy` kept in the repository, whose first
line records how it was made (the scenes, the reference folder and the preset, repository-relative).
CI recomputes it and fails when an error grows by more than ALLOWED_GROWTH (docs/validation.md).
Only the errors are compared; the times are those of the run that wrote the ledger."""
from __future__ import annotations

import math
import pathlib
import shlex

from gearmesh.accuracy_report import ERROR_COLUMNS

ALLOWED_GROWTH = 0.01  # 1 percentage point of |error|
_MAGIC = "# gearmesh-accuracy-ledger 1:"


def header(scenes: list[pathlib.Path], reference: pathlib.Path, preset: str,
           root: pathlib.Path) -> str:
    """The first line: the command's inputs, relative to `root` (the repository) where they lie
    inside it (a ledger to commit is made from the repository's files only)."""
    def rel(p: pathlib.Path) -> str:
        p = pathlib.Path(p).resolve()
        try:
            return p.relative_to(root.resolve()).as_posix()
        except ValueError:
            return str(p)

    parts = ["--settings", preset, "--reference", rel(reference), *(rel(s) for s in scenes)]
    return f"{_MAGIC} {shlex.join(parts)}"


def provenance(path: pathlib.Path) -> dict:
    """{'settings', 'reference', 'scenes'} from a ledger's first line (repository-relative)."""
    first = pathlib.Path(path).read_text().splitlines()[0] if pathlib.Path(path).is_file() else ""
    if not first.startswith(_MAGIC):
        raise ValueError(f"{path}: not an accuracy ledger (first line must start with "
                         f"{_MAGIC!r})")
    words = shlex.split(first[len(_MAGIC):])
    try:
        preset = words[words.index("--settings") + 1]
        reference = words[words.index("--reference") + 1]
    except (ValueError, IndexError):
        raise ValueError(f"{path}: first line needs --settings and --reference") from None
    scenes = [w for i, w in enumerate(words)
              if not w.startswith("--") and (i == 0 or not words[i - 1].startswith("--"))]
    return {"settings": preset, "reference": reference, "scenes": scenes}


def _key(row: dict) -> tuple:
    return (row["scene"], row.get("reference") or "2d", row["setting"], float(row["torque_Nm"]),
            row["quantity"])


def compare(committed: list[dict], new: list[dict], allowed: float = ALLOWED_GROWTH) -> list[str]:
    """What grew: every committed row's |error| (band, each model) that is more than `allowed`
    larger in `new`, and every committed row `new` lacks."""
    fresh = {_key(r): r for r in new}
    problems = []
    for row in committed:
        key = _key(row)
        if key not in fresh:
            problems.append(f"{key}: in the ledger, not recomputed")
            continue
        for column in ERROR_COLUMNS:
            old, now = abs(float(row[column])), abs(float(fresh[key].get(column, math.nan)))
            if math.isnan(old):
                continue  # a column of the other reference kind
            if not now - old <= allowed:
                problems.append(f"{key} {column}: |error| {100 * old:.2f} % -> {100 * now:.2f} % "
                                f"(allowed growth {100 * allowed:g} percentage point)")
    return problems
