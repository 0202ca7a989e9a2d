"""Helpers of the output files shared by the 2-D and 3-D runs: provenance (git commit, the
portable command line), CSV number format, the relative changes of a study, the cost."""
from __future__ import annotations

import datetime
import json
import os
import pathlib
import platform
import subprocess
import sys

import numpy as np

from . import analysis, ccx


def _git_commit(path: pathlib.Path) -> str:
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], cwd=path, capture_output=True,
                             text=True, timeout=30)
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "."], cwd=path,
                               capture_output=True, text=True, timeout=30).stdout.strip()
        return out.stdout.strip() + ("+modified reference_fe" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


# the commit of the code a run starts with (a long run's JSON is written at its end)
_COMMIT_AT_START = _git_commit(pathlib.Path(__file__).resolve().parent)


def _g(x) -> str:
    """A number for the CSV: shortest round-trip text of the float."""
    return repr(float(x))


def _portable_args(args):
    """The command line without machine paths: --cache DIR dropped (it does not change results),
    scene and output paths relative to the current directory."""
    out, skip = [], False
    for a in args:
        if skip:
            skip = False
            continue
        if a == "--cache":
            skip = True
            continue
        if a.startswith("--cache="):
            continue
        if os.path.isabs(a):
            try:
                a = os.path.relpath(a)
            except ValueError:
                pass
        out.append(a)
    return out


def provenance(scene_name: str, scene_path) -> dict:
    """The head of a JSON provenance record: scene, command, date, commit, tool versions."""
    return {
        "scene": scene_name,
        "scene_file": pathlib.Path(scene_path).name,
        "command": "python -m reference_fe " + " ".join(_portable_args(sys.argv[1:])),
        "date_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "git_commit": _COMMIT_AT_START,
        "ccx_version": ccx.ccx_version(),
        "python": platform.python_version(),
        "gmsh_version": __import__("gmsh").__version__,
    }


def _changes(base, other, torques):
    """Relative change (other - base) / base of mean and p-p TE at the same positions (the p-p
    change is None where the base's p-p is 0: a study at one position)."""
    rows = []
    for ti, T in enumerate(torques):
        sb = analysis.summary(base, ti)
        so = analysis.summary(other, ti)
        rows.append({"torque_Nm": T,
                     "mean_te_m": [sb["mean_te_m"], so["mean_te_m"]],
                     "pp_te_m": [sb["pp_te_m"], so["pp_te_m"]],
                     "mean_change": so["mean_te_m"] / sb["mean_te_m"] - 1,
                     "pp_change": (so["pp_te_m"] / sb["pp_te_m"] - 1) if sb["pp_te_m"] else None,
                     "pp_change_of_mean": (so["pp_te_m"] - sb["pp_te_m"]) / sb["mean_te_m"]})
    return rows


def _cost(results):
    w = [r.wall_s for r in results]
    m = [r.max_rss_MiB for r in results]
    return {"runs": len(w), "wall_s_total": float(np.sum(w)), "wall_s_per_position": float(np.mean(w)),
            "peak_rss_MiB": float(np.max(m))}


THREADS = "OMP_NUM_THREADS=1, CCX_NPROC_EQUATION_SOLVER=1, one ccx at a time"


def write_provenance(path: pathlib.Path, record: dict) -> None:
    """The JSON provenance record of a run's output files."""
    with open(path, "w") as f:
        json.dump(record, f, indent=1)
