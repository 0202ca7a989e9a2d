"""`gearmesh stability`: the stiff and extreme cases (gearmesh.stability.cases) x modes
(gearmesh.stability.runs) x communication steps, each run judged, with the expected outcome per
mode and step, a markdown and CSV table, and a plot of the largest stable step per case and mode
(docs/stability.md).

Judgement of a run: every output finite; no error status (FMI error, discarded step, failed
master); no unconverged solve; |energy residual| <= 1 % of the work in (initial energy + the
positive work of each source); for the cases at 10 rpm the TE against the converged dynamics
(the plain element under the implicit master at a tiny step), after the first 10 ms: mean and
peak-to-peak within 0.05 um; and the case's own checks (flanks hit, no contact, equal
continuations after a rollback). The undamped cases (nothing damps the mesh mode the start
excites) are judged against the run's own largest kinetic + elastic energy instead of the work
in, which balanced torques make large: the integrator made no energy (energy.residual >=
-UNDAMPED_GAIN of it), and the mesh oscillation did not grow (the largest normal force of the
second half no larger than that of the first).
"""
from __future__ import annotations

import csv
import math
import pathlib
import tempfile
import time
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

from gearmesh.stability.cases import SETTLE, Case, select
from gearmesh.stability.runs import MODES, Run, prepare, run

STEPS = [1e-6, 1e-5, 1e-4, 1e-3, 1e-2]
QUICK_STEPS = [1e-5, 1e-3, 1e-2]
TE_TOL = 0.05e-6       # m
ENERGY_TOL = 0.01      # of the work in
UNDAMPED_GAIN = 1e-3   # of the largest kinetic + elastic energy: energy an undamped run may make
ROLLBACK_TOL = 1e-12   # largest difference of the two continuations (rad, m)


@dataclass
class Row:
    case: str
    mode: str
    step: float
    passed: bool | None            # every judgement; None: not applicable
    stable: bool | None            # finite, no error, converged, energy
    expected: bool | None
    max_force: float
    energy: float                  # residual / work in
    te_error: float                # m, the larger of the mean and peak-to-peak differences
    nan_count: int
    unconverged: int
    retries: int
    cost: float                    # s per communication step (wall)
    internal_steps: float          # large-step mode: internal steps per communication step
    failed: str                    # which judgements failed (or the error), and notes
    cut_te_error: float = math.nan  # large_step_chain: TE off the converged chain (the cut's), m


def expected(case: Case, mode: str, step: float) -> bool | None:
    """What the suite expects of a run (all judgements); None = not asserted.

    * large-step mode: passes at every step (below 1e-3 s not asserted on SMALL_STEP_OPEN);
    * plain element, explicit master: fails from 1e-3 s on wherever the mesh is loaded (its
      limit is about 0.5 x 2/omega_mesh, 7e-5 s for set A on 0.02 kg m^2), passes at 1e-5 s
      on the cases of EXPLICIT_OK;
    * plain element, implicit master: passes at 1e-4 s and below on the cases of IMPLICIT_OK.
    """
    if mode == "large_step" and (case.random_steps or case.rollback):
        return None
    if case.modes and mode not in case.modes:
        return None
    if mode.startswith("large_step") and step < 1e-3 and case.name in SMALL_STEP_OPEN:
        return None
    if mode.startswith("large_step"):
        return True
    if mode == "explicit":
        if step >= 1e-3 and case.contact and case.loaded and case.name not in EXPLICIT_SURVIVES:
            return False
        return True if step <= 1e-5 and case.name in EXPLICIT_OK else None
    return True if step <= 1e-4 and case.name in IMPLICIT_OK else None


# The large-step mode below 1e-3 s, not asserted where measured off (the brief's steps are 1e-3
# and 1e-2 s, where every case is asserted): docs/stability.md, "Measured".
SMALL_STEP_OPEN = {
    "damping_0": "undamped, the start transient rings on: at 1e-5 s the p-p is 0.092 um off the "
                 "converged dynamics at dynamics.tolerance 1e-9 m, 0.0035 um at 1e-10, 0.0007 um "
                 "at 1e-11 (the FMU's own error, converging with its tolerance)",
}
# Loaded cases the plain element under the explicit master survives at 1e-2 s (measured: at
# 10 000 rpm a 1e-2 s step turns gear 1 by 10 rad, and the contact seen at the samples happens
# to stay bounded); reported, not asserted either way.
EXPLICIT_SURVIVES = {"speed_10000rpm"}

# Cases the plain element passes under the project's masters at small steps (measured,
# docs/stability.md); elsewhere the outcome is reported, not asserted.
EXPLICIT_OK = {"zero_load_contact", "free_in_backlash", "nominal", "level_4", "rollback"}
IMPLICIT_OK = {"zero_load_contact", "free_in_backlash", "nominal", "level_4", "rollback"}


def judge(case: Case, r: Run) -> tuple[bool | None, bool | None, str]:
    """(passed, stable, what failed): stable = finite, no error, converged, energy balance;
    passed = stable and accurate (TE, the case's own checks)."""
    if r.error.startswith("n/a"):
        return None, None, r.error
    unstable, inaccurate, notes = [], [], []
    if r.error:
        unstable.append(f"error: {r.error}")
    if r.nan_count:
        unstable.append(f"{r.nan_count} non-finite values")
    if r.unconverged:
        unstable.append(f"{r.unconverged} unconverged")
    if not r.error:
        rel = abs(r.residual) / r.work_in if r.work_in > 0 else math.inf
        if math.isnan(r.residual):
            notes.append("energy n/a: the FMU has no mesh.elastic_energy/mesh.damping_power")
        elif case.undamped:
            made = -r.residual / r.largest_energy if r.largest_energy > 0 else math.inf
            if not made <= UNDAMPED_GAIN:
                unstable.append(f"energy made: {made:.3g} of the largest energy")
            half = len(r.force) // 2
            if case.rattles:
                notes.append("rattles by its physics: the oscillation's growth is not judged")
            elif half and not np.max(r.force[half:]) <= np.max(r.force[:half]):
                unstable.append(f"the mesh oscillation grew: peak force {np.max(r.force[:half]):.0f} N, "
                                f"then {np.max(r.force[half:]):.0f} N")
        elif not rel <= ENERGY_TOL:
            unstable.append(f"energy residual {rel:.3g} of the work in")
        if case.te_check and not te_error(r) <= TE_TOL:
            inaccurate.append(f"TE {te_error(r) * 1e6:.3g} um off the " +
                              ("same cut with the gear pair converged" if r.te_cut is not None
                               else "converged dynamics"))
        if case.te_check and r.te_cut is not None:
            notes.append(f"explicit cut: {te_error(r, r.te_cut) * 1e6:.3g} um off the "
                         "converged chain")
        seen = set(np.unique(r.flank).astype(int)) if len(r.flank) else set()
        if case.flanks and not set(case.flanks) <= seen:
            inaccurate.append(f"flanks seen {sorted(seen)}, expected {list(case.flanks)}")
        if not case.contact and np.max(np.abs(r.force), initial=0.0) > 0:
            inaccurate.append("touched")
        if case.rollback and not r.rollback_gap <= ROLLBACK_TOL:
            inaccurate.append(f"rollback: continuations differ by {r.rollback_gap:.3g}")
    return (not unstable and not inaccurate, not unstable,
            "; ".join(unstable + inaccurate + notes))


def te_error(r: Run, reference: np.ndarray | None = None) -> float:
    """The larger of |mean difference| and |peak-to-peak difference| from the reference TE
    (default r.te_ref) over the judged window (after SETTLE)."""
    reference = r.te_ref if reference is None else reference
    if reference is None or not len(r.te):
        return math.nan
    keep = r.t >= min(SETTLE, r.t[-1])
    te, ref = r.te[keep], reference[keep]
    if not len(te) or not np.all(np.isfinite(te)):
        return math.inf
    return max(abs(te.mean() - ref.mean()), abs(np.ptp(te) - np.ptp(ref)))


def row(case: Case, r: Run) -> Row:
    passed, stable, failed = judge(case, r)
    rel = abs(r.residual) / r.work_in if r.work_in and r.work_in > 0 else math.nan
    force = np.abs(r.force[np.isfinite(r.force)]) if len(r.force) else np.zeros(0)
    return Row(case.name, r.mode, r.step, passed, stable, expected(case, r.mode, r.step),
               float(force.max()) if len(force) else math.nan, rel,
               te_error(r) if case.te_check else math.nan, r.nan_count, r.unconverged,
               r.retries, r.seconds / r.steps if r.steps else math.nan,
               r.internal_steps / r.steps if r.steps and r.internal_steps else math.nan, failed,
               te_error(r, r.te_cut) if case.te_check and r.te_cut is not None else math.nan)


def run_suite(fmu: pathlib.Path, cases: list[Case], modes: list[str], steps: list[float],
              progress: bool = True) -> list[Row]:
    rows = []
    with tempfile.TemporaryDirectory(prefix="gearmesh-stability-") as tmp:
        jobs = [(c, m, h) for c in cases for m in modes for h in steps]
        bar = tqdm(total=len(jobs), disable=not progress, desc="stability")
        for case in cases:
            prep = prepare(case, fmu, pathlib.Path(tmp))
            for mode in modes:
                for h in steps:
                    bar.set_postfix_str(f"{case.name} {mode} {h:g}")
                    rows.append(row(case, run(prep, mode, h)))
                    bar.update()
        bar.close()
    return rows


def largest_stable(rows: list[Row]) -> dict[tuple[str, str], float]:
    """Per (case, mode): the largest step at which the run and the runs at every smaller tested
    step are stable (0 if the smallest is not; n/a rows are left out)."""
    out = {}
    for key in dict.fromkeys((r.case, r.mode) for r in rows):
        best = 0.0
        for r in sorted((r for r in rows if (r.case, r.mode) == key and r.stable is not None),
                        key=lambda r: r.step):
            if not r.stable:
                break
            best = r.step
        out[key] = best
    return out


def _fmt(v: float, scale: float = 1.0, digits: int = 3) -> str:
    return "–" if v is None or not np.isfinite(v) else f"{v * scale:.{digits}g}"


def _mark(v: bool | None) -> str:
    return "n/a" if v is None else ("pass" if v else "FAIL")


def write_outputs(rows: list[Row], out: pathlib.Path, title: str = "Stability suite") -> dict:
    """table.csv, table.md, largest_stable_step.png; returns the summary figures."""
    out.mkdir(parents=True, exist_ok=True)
    fields = list(Row.__dataclass_fields__)
    with (out / "table.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(fields)
        for r in rows:
            w.writerow([getattr(r, f) for f in fields])
    summary = summarize(rows)
    md = [f"# {title}", "", *summary_lines(summary), "",
          "| case | mode | step (s) | result | stable | expected | max \\|F\\| (N) | energy residual "
          "(of work in) | TE error (um) | NaN | unconverged | retries | cost/step (ms) | "
          "internal steps/step | failed judgements, notes |", "|" + "---|" * 15]
    for r in rows:
        md.append(f"| {r.case} | {r.mode} | {r.step:g} | {_mark(r.passed)} | "
                  f"{'–' if r.stable is None else ('yes' if r.stable else 'no')} | {_mark(r.expected)}"
                  f" | {_fmt(r.max_force)} | {_fmt(r.energy)} | {_fmt(r.te_error, 1e6)} | "
                  f"{r.nan_count} | {r.unconverged} | {r.retries} | {_fmt(r.cost, 1e3)} | "
                  f"{_fmt(r.internal_steps)} | {r.failed.replace('|', '/')} |")
    (out / "table.md").write_text("\n".join(md) + "\n", encoding="utf-8")
    plot_largest_stable(rows, out / "largest_stable_step.png")
    return summary


def summarize(rows: list[Row]) -> dict:
    stable = largest_stable(rows)
    modes = list(dict.fromkeys(r.mode for r in rows))
    s = {"runs": len(rows), "passed": sum(r.passed is True for r in rows),
         "unexpected": [r for r in rows if r.expected is not None and r.passed is not None
                        and r.passed != r.expected],
         "largest_stable": {}, "pass_counts": {}, "cost": {}}
    for m in modes:
        vals = [v for (c, mm), v in stable.items() if mm == m]
        s["largest_stable"][m] = (min(vals), float(np.median(vals)), max(vals)) if vals else None
        for h in sorted({r.step for r in rows}):
            sel = [r for r in rows if r.mode == m and r.step == h and r.passed is not None]
            s["pass_counts"][(m, h)] = (sum(bool(r.passed) for r in sel), len(sel))
            costs = [r.cost for r in sel if np.isfinite(r.cost)]
            if costs:
                s["cost"][(m, h)] = float(np.median(costs))
    return s


def summary_lines(s: dict) -> list[str]:
    lines = [f"{s['passed']} of {s['runs']} runs pass; {len(s['unexpected'])} differ from the "
             "expectation.", "", "| mode | largest stable step (s): min / median / max over "
             "the cases | passing runs per step | median cost per communication step (ms) |",
             "|---|---|---|---|"]
    for m, v in s["largest_stable"].items():
        counts = ", ".join(f"{h:g}: {p}/{n}" for (mm, h), (p, n) in s["pass_counts"].items()
                           if mm == m)
        costs = ", ".join(f"{h:g}: {c * 1e3:.3g}" for (mm, h), c in s["cost"].items() if mm == m)
        stable = "–" if v is None else f"{v[0]:g} / {v[1]:g} / {v[2]:g}"
        lines.append(f"| {m} | {stable} | {counts} | {costs} |")
    for r in s["unexpected"]:
        lines.append(f"\nUnexpected: {r.case} {r.mode} {r.step:g} s: {_mark(r.passed)} "
                     f"({r.failed or 'all judgements passed'})")
    return lines


def plot_largest_stable(rows: list[Row], path: pathlib.Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    stable = largest_stable(rows)
    cases = list(dict.fromkeys(r.case for r in rows))
    modes = list(dict.fromkeys(r.mode for r in rows))
    steps = sorted({r.step for r in rows})
    floor = steps[0] / 10  # "fails at every step" drawn below the smallest step
    fig, ax = plt.subplots(figsize=(max(7, 0.32 * len(cases) + 2), 4.5))
    x = np.arange(len(cases))
    applicable = {(r.case, r.mode) for r in rows if r.stable is not None}  # n/a: not drawn
    for k, m in enumerate(modes):
        y = [(stable[(c, m)] or floor) if (c, m) in applicable else math.nan for c in cases]
        ax.scatter(x + (k - (len(modes) - 1) / 2) * 0.15, y, label=m, s=22)
    ax.set_yscale("log")
    ax.axhline(floor * 1.5, color="grey", lw=0.5, ls=":")
    ax.set_xticks(x, cases, rotation=70, ha="right", fontsize=7)
    ax.set_ylabel("largest stable step (s)")
    ax.set_title("largest step stable at it and every smaller step (finite, converged, energy "
                 f"balance)\nsteps {', '.join(f'{h:g}' for h in steps)}; {floor:g} = none; n/a "
                 "not drawn", fontsize=9)
    ax.grid(True, alpha=0.3, which="both")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def parse_steps(text: list[str] | None, quick: bool) -> list[float]:
    if not text:
        return list(QUICK_STEPS if quick else STEPS)
    steps = []
    for t in text:
        for part in t.split(","):
            try:
                h = float(part)
            except ValueError:
                raise ValueError(f"--steps: {part!r} is not a number (s)") from None
            if not 1e-7 <= h <= 0.1:
                raise ValueError(f"--steps: {h:g} s outside the allowed range [1e-07, 0.1] s")
            steps.append(h)
    return sorted(set(steps))


def parse_modes(text: list[str] | None) -> list[str]:
    modes = [m for t in (text or MODES) for m in t.split(",") if m]
    bad = [m for m in modes if m not in MODES]
    if bad:
        raise ValueError(f"--modes: unknown mode(s) {', '.join(bad)}; allowed: {', '.join(MODES)}")
    return list(dict.fromkeys(modes))


def main(fmu: pathlib.Path, cases: list[str] | None, modes: list[str] | None,
         steps: list[str] | None, out: pathlib.Path, quick: bool) -> int:
    """The CLI's `stability` command; exit 1 if a run differs from its expectation."""
    names = [n for t in (cases or []) for n in t.split(",") if n] or None
    selected = select(names, quick)
    start = time.perf_counter()
    rows = run_suite(fmu, selected, parse_modes(modes), parse_steps(steps, quick))
    summary = write_outputs(rows, out)
    print("\n".join(summary_lines(summary)))
    print(f"gearmesh: {len(rows)} runs in {time.perf_counter() - start:.1f} s: "
          f"{out / 'table.md'}, {out / 'table.csv'}, {out / 'largest_stable_step.png'}")
    return 1 if summary["unexpected"] else 0


MAIN_JOB_CASES = ["nominal", "rattle"]
MAIN_JOB_STEPS = [1e-4, 1e-3]


def main_job_section(fmu: pathlib.Path, out: pathlib.Path) -> str:
    """The main job's report section: a small subset of the suite (two cases, every mode,
    1e-4 and 1e-3 s) with its table under out/stability/."""
    rows = run_suite(fmu, select(MAIN_JOB_CASES), MODES, MAIN_JOB_STEPS, progress=False)
    folder = out / "stability"
    write_outputs(rows, folder, "Stability subset of the main job")
    lines = ["## Stability (subset)", "",
             f"Cases {', '.join(MAIN_JOB_CASES)} in every mode at "
             f"{', '.join(f'{h:g}' for h in MAIN_JOB_STEPS)} s (the whole suite: "
             "`gearmesh stability`, docs/stability.md). Table: `stability/table.md`.",
             "", "| case | mode | step (s) | result | max \\|F\\| (N) | energy residual | "
             "TE error (um) | cost/step (ms) |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r.case} | {r.mode} | {r.step:g} | {_mark(r.passed)} | "
                     f"{_fmt(r.max_force)} | {_fmt(r.energy)} | {_fmt(r.te_error, 1e6)} | "
                     f"{_fmt(r.cost, 1e3)} |")
    return "\n".join(lines + [""])
