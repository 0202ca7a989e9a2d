"""The outputs of `gearmesh accuracy`: the tidy CSV (one row per scene, setting, torque and
quantity), the per-setting summary (worst error against the band, cost), the markdown table, the
Pareto plot, and the cheapest setting within a tolerance. A scene with a 2-D and a 3-D reference
has a section and a front for each."""
from __future__ import annotations

import csv
import math
import shlex
import pathlib
from collections import defaultdict

from gearmesh.accuracy.reference import (CURVE, LOAD_SHARE, PAIR_LINE_LOAD, PEAK_LINE_LOAD, QUANTITIES, SCORED,
                                         WHOLE)

# reference: "2d" (plane_* columns filled) or "3d" (fe3d columns filled); the others are empty.
# product, plane_stress, plane_strain, fe3d: the quantity's values in its unit (SI; "1" for a share)
COLUMNS = ["scene", "reference", "setting", "level", "slices", "coupled_teeth", "torque_Nm",
           "quantity", "unit", "product", "plane_stress", "plane_strain", "fe3d", "band_error",
           "error_plane_stress", "error_plane_strain", "error_fe3d", "plain_us", "plain_raw_us",
           "quasi_static_us", "quasi_static_raw_us", "round_trip_us", "fe_variant", "db_build_s",
           "db_peak_MiB"]
ERROR_COLUMNS = ("band_error", "error_plane_stress", "error_plane_strain", "error_fe3d")
TIME_COLUMNS = ("plain_us", "plain_raw_us", "quasi_static_us", "quasi_static_raw_us",
                "round_trip_us")
DATABASE_COLUMNS = ("db_build_s", "db_peak_MiB")  # level 5: the databases' build (NaN elsewhere)
# A setting's score: the largest |band error| over the torques and its reference's SCORED.
# CURVE, LOAD_SHARE, PAIR_LINE_LOAD, PEAK_LINE_LOAD: n/a where the reference has no per-position,
# per-tooth or line-load file (or, for PEAK_LINE_LOAD, not the setting's slice count)
SHOWN = (*QUANTITIES, CURVE, LOAD_SHARE, PAIR_LINE_LOAD, PEAK_LINE_LOAD)
_REFERENCE_TITLE = {"2d": "2-D band [plane stress, plane strain], whole gears",
                    "3d": "3-D sectors (ripple scored; the mean is biased low by the sectors)",
                    WHOLE: "3-D, the mean of whole gears (measured or corrected to them; mean and "
                           "ripple scored)"}


def write_csv(path: pathlib.Path, rows: list[dict], first_line: str = "",
              columns: list[str] = COLUMNS) -> pathlib.Path:
    """`first_line`: a comment (starting with '#') written before the header, if given."""
    with pathlib.Path(path).open("w", newline="") as fh:
        if first_line:
            fh.write(first_line + "\n")
        writer = csv.DictWriter(fh, columns)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: (f"{v:.9g}" if isinstance(v, float) else v)
                             for k, v in row.items()})
    return pathlib.Path(path)


def read_csv(path: pathlib.Path) -> list[dict]:
    """The rows with numbers as floats (an empty cell: NaN; no reference column: a 2-D row)."""
    with pathlib.Path(path).open(newline="") as fh:
        rows = list(csv.DictReader(line for line in fh if not line.startswith("#")))
    for row in rows:
        row["reference"] = row.get("reference") or "2d"
        for key in ("torque_Nm", "product", "plane_stress", "plane_strain", "fe3d",
                    *ERROR_COLUMNS, *TIME_COLUMNS, *DATABASE_COLUMNS):
            row[key] = float(row.get(key) or "nan")
    return rows


def groups(entries: list[dict]) -> dict[tuple[str, str], list[dict]]:
    """(scene, reference) -> its rows or entries, in order of appearance."""
    out: dict[tuple[str, str], list[dict]] = defaultdict(list)
    for e in entries:
        out[(e["scene"], e["reference"])].append(e)
    return out


def per_setting(rows: list[dict]) -> list[dict]:
    """One entry per (scene, reference, setting): the worst signed band error per quantity, the
    score and the cost (from the rows, which repeat a setting's cost)."""
    by_setting: dict[tuple, list[dict]] = defaultdict(list)
    for row in rows:
        by_setting[(row["scene"], row["reference"], row["setting"])].append(row)
    out = []
    for (scene, reference, setting), group in by_setting.items():
        entry = {"scene": scene, "reference": reference, "setting": setting,
                 "level": group[0]["level"], **{k: group[0][k] for k in TIME_COLUMNS},
                 **{k: _number(group[0].get(k)) for k in DATABASE_COLUMNS}}
        for q in SHOWN:
            errors = [r["band_error"] for r in group if r["quantity"] == q]
            entry[q] = max(errors, key=abs) if errors else math.nan
        entry["score"] = max(abs(entry[q]) for q in SCORED[reference] if not math.isnan(entry[q]))
        out.append(entry)
    return out


def _number(value) -> float:
    return math.nan if value in (None, "") else float(value)


def database(entry: dict) -> str:
    """A level-5 entry's database build (time over both gears, peak memory) as text."""
    if math.isnan(entry["db_build_s"]):
        return ""
    return f"{entry['db_build_s']:.0f} s, {entry['db_peak_MiB'] / 1024:.1f} GiB"


SCORE_RESOLUTION = 1e-6  # scores closer than this are equal (settings that differ in cost only)


def pareto_front(entries: list[dict], cost: str = "plain_us") -> list[dict]:
    """The entries no other entry beats in both cost and score, cheapest first."""
    front, best = [], math.inf
    for e in sorted(entries, key=lambda e: (e[cost], e["score"])):
        if e["score"] < best - SCORE_RESOLUTION:
            front.append(e)
            best = e["score"]
    return front


def cheapest_within(entries: list[dict], tolerance: float, cost: str = "plain_us") -> dict | None:
    inside = [e for e in entries if e["score"] <= tolerance]
    return min(inside, key=lambda e: (e[cost], e["quasi_static_us"])) if inside else None


def pct(x: float) -> str:
    """A relative error as text: n/a, 0 (inside the band) or a signed per cent."""
    if math.isnan(x):
        return "n/a"
    return f"{100 * x:+.1f} %" if x else "0"


def markdown(entries: list[dict], tolerance: float, notes: list[str]) -> str:
    lines = ["# Accuracy against run time", "",
             "Error of the loaded TE against the FE references (reference_fe/README.md). 2-D: "
             "the band [plane stress, plane strain] of whole gears, 0 inside the band, else the "
             "signed distance to the nearer edge relative to it. 3-D: sectors of both gears, the "
             "relative error; their mean TE is biased low by the sectors' held cut faces, so "
             "they score the ripple only, unless the model is of whole gears or the sector bias "
             "was measured against whole gears and removed from the mean (3d-whole). Torque: on "
             "gear 1 at every position, as the references load it (gear 2's load corrected "
             "until gear 1's contact moment is the torque). Per quantity the worst over the torques. Score: the "
             f"largest |error| over {', '.join(SCORED['2d'])} (2-D) or "
             f"{', '.join(SCORED['3d'])} (3-D; 3d-whole: {', '.join(SCORED[WHOLE])}). Cost: median time per fmi2DoStep "
             "through fmpy minus the bare fmpy round trip (raw: without the subtraction), plain "
             "mode (prescribed spins) and quasi-static mode. Database build (level 5): compliance_tool's "
             "wall time over the distinct gear databases and its largest peak memory, from the "
             "build cache. TE curve: the worst distance of the "
             "TE to the band of the two models position by position (a p-p or an order outside "
             "the band of p-p values can come from a curve inside the band everywhere). Load "
             "share: the most loaded tooth pair's share of the force (mesh.max_load_share) "
             "against the band of the models' position by position; pair line load: that pair's "
             "force over the face width, the largest over the positions, against the band of "
             "the models' largest "
             "(2-D references with per-tooth forces). Peak line load (3-D references with the "
             "line load across the face, shown, not scored): mesh.max_line_load, the largest "
             "over the positions, against the reference's largest bin line load at as many bins "
             "as the setting's slices. The error against each model is in "
             "accuracy.csv.", ""]
    lines += [f"* {n}" for n in notes]
    for (scene, kind), group in groups(entries).items():
        front = {id(e) for e in pareto_front(group)}
        lines += ["", f"## {scene}: {_REFERENCE_TITLE[kind]}", "",
                  "| setting | mean TE | p-p TE | order 1 | order 2 | order 3 | TE curve | "
                  "load share | pair line load | peak line load | score | plain µs (raw) | "
                  "quasi-static µs (raw) | database build | front |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for e in group:
            lines.append(
                f"| {e['setting']} | " + " | ".join(pct(e[q]) for q in SHOWN)
                + f" | {100 * e['score']:.1f} % | {e['plain_us']:.1f} ({e['plain_raw_us']:.1f})"
                f" | {e['quasi_static_us']:.1f} ({e['quasi_static_raw_us']:.1f}) | {database(e)} | "
                + ("yes" if id(e) in front else "") + " |")
        best = cheapest_within(group, tolerance)
        lines += ["", f"Cheapest setting within {100 * tolerance:g} %: "
                  + (f"**{best['setting']}** (score {100 * best['score']:.1f} %, "
                     f"{best['plain_us']:.1f} µs plain)" if best else "none")]
    return "\n".join(lines) + "\n"


def plot(path: pathlib.Path, entries: list[dict], floor_us: float = 0.1) -> pathlib.Path:
    """Score against plain-mode µs per evaluation (log x), one point per setting and scene, the
    front of each scene drawn as a line; costs below `floor_us` (the round trip's noise) are
    drawn at the floor."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5))
    for (scene, kind), group in groups(entries).items():
        x = [max(e["plain_us"], floor_us) for e in group]
        points = ax.scatter(x, [100 * e["score"] for e in group], s=18, alpha=0.6,
                            label=f"{scene} ({kind}): settings")
        front = pareto_front(group)
        ax.plot([max(e["plain_us"], floor_us) for e in front], [100 * e["score"] for e in front],
                "o-", color=points.get_facecolor()[0][:3], lw=2, label=f"{scene} ({kind}): front")
        for e in front:
            ax.annotate(e["setting"], (max(e["plain_us"], floor_us), 100 * e["score"]),
                        fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.set(xscale="log", xlabel="µs per evaluation, plain mode (fmi2DoStep minus the fmpy round "
           "trip)", ylabel="score: largest |error| against the FE reference, %",
           title="Accuracy against run time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return pathlib.Path(path)


def parse_tolerance(text: str) -> float:
    """'5%' or '0.05' -> 0.05; allowed (0, 100 %]."""
    stripped = text.strip()
    try:
        value = float(stripped[:-1]) / 100 if stripped.endswith("%") else float(stripped)
    except ValueError:
        raise ValueError(f"--tolerance {text!r}: not a number; allowed: e.g. 5% or 0.05") from None
    if not 0 < value <= 1:
        raise ValueError(f"--tolerance {text!r}: outside the allowed range (0, 100%]")
    return value


# The first line of an accuracy table (accuracy.csv, and the committed ledgers made from it):
# the command's inputs, so that the table can be made again.
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
    return {"settings": preset, "reference": reference, "scenes": scenes, "first_line": first}
