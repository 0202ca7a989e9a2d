"""A study's report: study_report.md with the distribution of peak-to-peak TE and of the first
mesh order per torque (study_distribution.png), their quantiles, and the worst cases with the
values drawn for them."""
from __future__ import annotations

import pathlib

import numpy as np

from gearmesh.batch.run import BatchResult
from gearmesh.batch.study import Plan


def plot(path: pathlib.Path, summary: list[dict]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    torques = sorted({r["torque_Nm"] for r in summary})
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, key, title in ((axes[0], "ptp_te_m", "peak-to-peak TE"),
                           (axes[1], "order1_m", "mesh order 1 amplitude")):
        for t in torques:
            x = [r[key] * 1e6 for r in summary if r["torque_Nm"] == t]
            ax.hist(x, bins=max(5, min(50, len(x) // 5)), alpha=0.6, label=f"{t:g} N m on gear 2")
        ax.set(xlabel=f"{title} (um)", ylabel="cases", title=title)
        ax.grid(True, alpha=0.3)
        ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write(plan: Plan, result: BatchResult, worst: int = 10) -> pathlib.Path:
    """study_report.md (and its plot) in the plan's folder; returns its path."""
    out, summary = plan.out, result.summary_rows
    lines = ["# GearMesh study", "", f"Scene `{plan.scene.path}`, {plan.cases} cases, seed "
             f"{plan.seed} (numpy default_rng; study.json records the draws):", ""]
    lines += [f"* `{s.text}`" for s in plan.samples]
    lines += ["", f"{len(summary)} case x torque results; {len(result.errors)} failed "
              "(batch_errors.csv).", ""]
    if summary:
        plot(out / "study_distribution.png", summary)
        lines += ["| load on gear 2 (N m) | quantity | median (um) | 95 % (um) | max (um) |",
                  "|---|---|---|---|---|"]
        for t in sorted({r["torque_Nm"] for r in summary}):
            for key, name in (("ptp_te_m", "p-p TE"), ("order1_m", "order 1")):
                x = np.array([r[key] for r in summary if r["torque_Nm"] == t]) * 1e6
                lines.append(f"| {t:g} | {name} | {np.median(x):.4g} | "
                             f"{np.quantile(x, 0.95):.4g} | {x.max():.4g} |")
        lines += ["", "![distribution](study_distribution.png)", "",
                  f"## The {min(worst, len(summary))} worst by peak-to-peak TE", ""]
        drawn = [s for s in plan.samples if s.name in summary[0]]
        pitches = [s for s in plan.samples if s.name not in summary[0]]
        head = ["case", "load on gear 2 (N m)", "p-p TE (um)", "order 1 (um)", "order 2 (um)",
                *(f"{s.name} ({s.unit or 'SI'})" for s in drawn),
                *(f"{s.name} max abs (um)" for s in pitches)]
        lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for r in sorted(summary, key=lambda r: -r["ptp_te_m"])[:worst]:
            cells = [str(r["case"]), f"{r['torque_Nm']:g}", *(f"{r[k] * 1e6:.4g}" for k in
                     ("ptp_te_m", "order1_m", "order2_m")),
                     *(f"{r[s.name] * s.factor:.4g}" for s in drawn),
                     *(f"{np.abs(plan.values[s.name][r['case']]).max() * 1e6:.4g}"
                       for s in pitches)]
            lines.append("| " + " | ".join(cells) + " |")
        lines += ["", "Pitch deviations of a case: deviations/case<NNNNNN>.gear<i>.txt.", ""]
    report = out / "study_report.md"
    report.write_text("\n".join(lines), encoding="utf-8")
    return report
