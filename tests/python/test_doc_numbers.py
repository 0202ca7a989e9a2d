"""A figure quoted in the guide is the figure where it is measured: the system-simulation guide's
passing runs against docs/stability.md's tables. A quote that drifts from its source fails here.
(The README's accuracy table per level is generated from the ledgers: test_reference_docs.)"""
from __future__ import annotations

import re
from conftest import REPO



def table_after(text: str, anchor: str) -> list[list[str]]:
    """The rows (cells stripped) of the first Markdown table after `anchor`, header first."""
    rest = text[text.index(anchor):]
    lines = rest.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("|"))
    rows = []
    for line in lines[start:]:
        if not line.startswith("|"):
            break
        if re.fullmatch(r"\|(\s*-+\s*\|)+", line.replace(":", "")):
            continue
        rows.append([c.strip() for c in line.strip().strip("|").split("|")])
    return rows


def as_dicts(rows: list[list[str]]) -> list[dict[str, str]]:
    return [dict(zip(rows[0], r)) for r in rows[1:]]


def section(text: str, heading: str) -> str:
    start = text.index(heading)
    end = text.find("\n## ", start + len(heading))
    return text[start:end if end > 0 else len(text)]


def passing(cell: str) -> dict[str, str]:
    """'1e-05: 29/30, 0.001: 33/33' (bold marks dropped) -> {step: 'n/m'}."""
    return dict(re.findall(r"([\d.e-]+): (\d+/\d+)", cell.replace("**", "")))


def test_system_simulation_table_quotes_the_stability_suite():
    guide = (REPO / "docs" / "guide" / "system-simulation.md").read_text(encoding="utf-8")
    stability = (REPO / "docs" / "stability.md").read_text(encoding="utf-8")
    measured: dict[str, dict[str, str]] = {}
    # every table of stability.md with a "passing runs per step" column, in order: later
    # (re-run) tables override earlier ones for the steps they hold
    for match in re.finditer(r"^\| mode \|.*passing runs per step", stability, re.M):
        for row in as_dicts(table_after(stability[match.start():], "| mode |")):
            measured.setdefault(row["mode"], {}).update(passing(row["passing runs per step"]))
    rows = as_dicts(table_after(section(guide, "## Which mode at which step"), "| element mode |"))
    mode_of = {("plain", "explicit"): "explicit", ("plain", "implicit"): "implicit",
               ("large-step", "fixed-step"): "large_step", ("large-step", "motor"): "large_step_chain"}
    steps = {"1e-5 s": "1e-05", "1e-4 s": "0.0001", "1e-3 s": "0.001", "1e-2 s": "0.01"}
    checked = 0
    for row in rows:
        mode = next(v for (m, master), v in mode_of.items()
                    if row["element mode"] == m and row["master"].startswith(master))
        for column, step in steps.items():
            assert row[column] == measured[mode][step], (
                f"docs/guide/system-simulation.md, {mode} at {column}: {row[column]} but "
                f"docs/stability.md says {measured[mode][step]}")
            checked += 1
    assert checked == 16
