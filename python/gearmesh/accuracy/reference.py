"""The FE references of a scene (reference_fe/README.md, "Outputs", "3-D cases") and the errors
against them.

2-D: `<scene>.reference_fe.summary.csv` holds, per model (plane_strain, plane_stress) and torque, the
mean, peak-to-peak and mesh orders 1-3 of the loaded TE over one pitch. The 3-D truth lies between
the two models: the band [min, max] of the two values of each quantity. The error of a product
value against the band is 0 inside it, else the signed distance to the nearer edge relative to
that edge; against one model it is (product - model) / model.

The band of a peak-to-peak or an order amplitude is not a bound on the 3-D truth: a curve that
lies between the two models at every position can have a larger p-p than either (stiff like
plane strain where two pairs carry, soft like plane stress where one does). So the TE curve is
also compared position by position (`<scene>.reference_fe.te.csv`): the quantity "curve" is the
worst signed distance of the product's TE to the band of the two models at the same position.
Where the reference has the per-tooth contact forces (`<scene>.reference_fe.pairs.csv`), the
most loaded tooth pair's share of the force is compared position by position ("load_share", with
the FMU's mesh.max_load_share), and that pair's force over the face width, largest over the
positions, with the band of the models' ("pair_line_load"). A plane model spreads a pair's force
evenly over the face, so this is the face-average line load of the most loaded pair: the product's
is mesh.max_load_share x mesh.normal_force / face width, not mesh.max_line_load (the largest
slice's, which at level 5 with several slices resolves the load across the face that the 2-D
reference cannot: docs/validation.md, "Load share and line load").

3-D line load: `<scene>.reference_fe3d.lineload.csv` (reference_fe/README.md, "3-D line load")
holds the contact force of each loaded tooth in bins across the face, at several bin counts.
"peak_line_load" compares the product's mesh.max_line_load (its largest slice's force over the
slice width), the largest over the positions, with the reference's largest bin line load over
the teeth and positions at the same bin count as the setting's slices (like with like: a slice
is a bin of the same width); no row where the reference has no such bin count. Shown, not
scored: the sectors that bias the 3-D TE's level (held cut faces, stiffer) also shape the load
distribution across the face, and the line load has a layer study at one position only.

3-D: `<scene>.reference_fe3d.summary.csv` holds one model (3-D sectors of both gears or whole
gears, a name starting with "3d_"); its "band" is that one value, so the band error is the
relative error. A sector model's mean TE is biased low by the sectors' held cut faces
(reference_fe/README.md, "3-D cases"), so such a 3-D reference scores the ripple only
(SCORED["3d"]: p-p and mesh orders 1-2; at its 8 positions per pitch order 3 aliases with order
5); mean, order 3 and curve are shown, not scored. A reference of whole gears (model name ending
in "_whole"), or a sector reference whose bias was measured against whole gears
(`<scene>.reference_fe3d.sector.csv`, reference_fe/README.md, "Sector bias"), scores the mean
too (SCORED["3d-whole"]; its rows are labelled "3d-whole"): the sector study's TE difference
whole - sector, averaged over its positions, is added to the sector reference's mean (the body's
compliance adds to the TE at every position alike; the spread over the positions is the
correction's uncertainty, `Reference.mean_correction`); the per-position TE of the "curve" gets the
same offset.
"""
from __future__ import annotations

import csv
import math
import pathlib
from dataclasses import dataclass

MODELS = ("plane_stress", "plane_strain")  # of a 2-D reference
MODEL_3D_PREFIX = "3d_"  # the one model of a 3-D reference: 3d_spur, 3d_helical, ...
KINDS = ("2d", "3d")
WHOLE = "3d-whole"  # the label of a 3-D reference whose mean is free of the sector bias
WHOLE_SUFFIX = "_whole"  # a 3-D model of whole gears (reference_fe run3d --sector-deg 360)
_FILE_STEM = {"2d": "reference_fe", "3d": "reference_fe3d"}
QUANTITIES = ("mean", "pp", "order1", "order2", "order3")  # the summary's <q>_te_m / <q>_m columns
CURVE = "curve"  # the TE position by position against the per-position band (te.csv)
LOAD_SHARE = "load_share"  # the most loaded pair's share, position by position (pairs.csv)
PAIR_LINE_LOAD = "pair_line_load"  # the most loaded pair's force / face width, largest (pairs.csv)
PEAK_LINE_LOAD = "peak_line_load"  # the largest bin / slice line load, largest (lineload.csv)
MIN_POSITIONS = 8  # per pitch: mesh order 3 below the Nyquist order (n/2)
# The quantities a reference of each kind scores (a setting's score: the largest |band error|).
SCORED = {"2d": (*QUANTITIES, LOAD_SHARE, PAIR_LINE_LOAD), "3d": ("pp", "order1", "order2"),
          WHOLE: ("mean", "pp", "order1", "order2")}
_COLUMNS = {"mean": "mean_te_m", "pp": "pp_te_m", "order1": "order1_m", "order2": "order2_m",
            "order3": "order3_m"}
_REQUIRED = ("scene", "model", "torque_Nm", "n_positions", *_COLUMNS.values())


class ReferenceError(ValueError):
    """A reference summary is missing, malformed or incomplete; the message names file and field."""


@dataclass(frozen=True)
class Reference:
    scene: str
    path: pathlib.Path
    n_positions: int
    # (model, torque in N m) -> quantity -> value in m
    values: dict[tuple[str, float], dict[str, float]]
    kind: str = "2d"  # one of KINDS
    models: tuple[str, ...] = MODELS  # 2-D: MODELS; 3-D: its one model
    # a sector reference's mean corrected to whole gears: torque -> (added offset, uncertainty), m
    mean_correction: dict[float, tuple[float, float]] | None = None

    @property
    def label(self) -> str:
        """The rows' "reference": the kind, or WHOLE for a 3-D mean free of the sector bias."""
        if self.kind == "3d" and (self.models[0].endswith(WHOLE_SUFFIX) or self.mean_correction):
            return WHOLE
        return self.kind

    @property
    def torques(self) -> list[float]:
        return sorted({t for _, t in self.values})

    def band(self, torque: float, quantity: str) -> tuple[float, float]:
        values = [self.values[(m, torque)][quantity] for m in self.models]
        return min(values), max(values)


def summary_path(reference_dir: pathlib.Path, scene_name: str, kind: str = "2d") -> pathlib.Path:
    return pathlib.Path(reference_dir) / f"{scene_name}.{_FILE_STEM[kind]}.summary.csv"


def _kind_of(path: pathlib.Path, models: set[str]) -> tuple[str, tuple[str, ...]]:
    """2-D: every model in MODELS; 3-D: one model named 3d_*."""
    if models <= set(MODELS):
        return "2d", MODELS
    if len(models) == 1 and min(models).startswith(MODEL_3D_PREFIX):
        return "3d", (min(models),)
    raise ReferenceError(f"{path}: model(s) {', '.join(sorted(models))}; allowed: "
                         f"{', '.join(MODELS)} (2-D) or one model {MODEL_3D_PREFIX}* (3-D)")


def read_summary(path: pathlib.Path) -> Reference:
    """Read a summary; lines starting with '#' are comments; rows of a "case" other than "base"
    (a 3-D file's studies) are skipped. 2-D: every torque must have both models; 3-D: one model.
    One n_positions for the whole file."""
    path = pathlib.Path(path)
    try:
        with path.open(newline="") as fh:
            rows = list(csv.DictReader(line for line in fh if not line.lstrip().startswith("#")))
    except OSError as exc:
        raise ReferenceError(f"{path}: cannot read the reference summary ({exc.strerror})") from exc
    rows = [r for r in rows if r.get("case", "base") == "base"]
    if not rows:
        raise ReferenceError(f"{path}: no rows")
    missing = [c for c in _REQUIRED if c not in rows[0]]
    if missing:
        raise ReferenceError(f"{path}: missing column(s) {', '.join(missing)}; required: "
                             f"{', '.join(_REQUIRED)}")
    values: dict[tuple[str, float], dict[str, float]] = {}
    scenes, counts = set(), set()
    kind, models = _kind_of(path, {row["model"] for row in rows})
    for line, row in enumerate(rows, start=2):
        try:
            torque = float(row["torque_Nm"])
            counts.add(int(row["n_positions"]))
            quantities = {q: float(row[c]) for q, c in _COLUMNS.items()}
        except ValueError as exc:
            raise ReferenceError(f"{path}: row {line}: {exc}") from exc
        if not all(math.isfinite(v) for v in quantities.values()) or quantities["mean"] <= 0:
            raise ReferenceError(f"{path}: row {line}: values must be finite and mean_te_m > 0")
        if (row["model"], torque) in values:
            raise ReferenceError(f"{path}: row {line}: {row['model']} at {torque:g} N m twice")
        scenes.add(row["scene"])
        values[(row["model"], torque)] = quantities
    if len(scenes) != 1:
        raise ReferenceError(f"{path}: rows of {len(scenes)} scenes ({', '.join(sorted(scenes))}); "
                             "allowed: one")
    if len(counts) != 1 or min(counts) < MIN_POSITIONS:
        raise ReferenceError(f"{path}: n_positions = {sorted(counts)}; allowed: one value >= "
                             f"{MIN_POSITIONS}")
    for model, torque in list(values):
        for other in models:
            if (other, torque) not in values:
                raise ReferenceError(f"{path}: {model} at {torque:g} N m has no {other} row "
                                     "(the band needs both models)")
    return Reference(scenes.pop(), path, counts.pop(), values, kind, models)


def _rows(path: pathlib.Path, n_positions: int, parse):
    """parse(row) of the rows of a reference CSV with n_positions = n ('#' lines are comments),
    None results left out; a KeyError or ValueError of a row is a ReferenceError naming file and
    row."""
    with path.open(newline="") as fh:
        reader = csv.DictReader(text for text in fh if not text.lstrip().startswith("#"))
        for line, row in enumerate(reader, start=2):
            try:
                value = parse(row) if int(row["n_positions"]) == n_positions else None
            except (KeyError, ValueError) as exc:
                raise ReferenceError(f"{path}: row {line}: {exc}") from exc
            if value is not None:
                yield value


def _require_positions(path: pathlib.Path, what: str, by_position: dict, n_positions: int):
    if sorted(by_position) != list(range(n_positions)):
        raise ReferenceError(f"{path}: {what} has positions {sorted(by_position)}; required: "
                             f"0..{n_positions - 1}")


def sector_path(reference_dir: pathlib.Path, scene_name: str) -> pathlib.Path:
    return pathlib.Path(reference_dir) / f"{scene_name}.reference_fe3d.sector.csv"


def read_sector(path: pathlib.Path) -> dict[float, tuple[float, float]]:
    """From a sector study (reference_fe sector3d): torque -> (mean over its positions of the TE
    of whole gears minus that of the smallest sector, the largest deviation of that difference
    from its mean over the positions); {} when the file does not exist."""
    path = pathlib.Path(path)
    if not path.is_file():
        return {}
    te: dict[tuple[float, float, int], float] = {}
    whole: set[float] = set()
    with path.open(newline="") as fh:
        reader = csv.DictReader(text for text in fh if not text.lstrip().startswith("#"))
        for line, row in enumerate(reader, start=2):
            try:
                key = (float(row["sector_deg"]), float(row["torque_Nm"]), int(row["position"]))
                te[key] = float(row["te_m"])
                if int(row["whole"]):
                    whole.add(key[0])
            except (KeyError, ValueError) as exc:
                raise ReferenceError(f"{path}: row {line}: {exc}") from exc
    if len(whole) != 1:
        raise ReferenceError(f"{path}: {len(whole)} whole-gear models; required: one")
    full = whole.pop()
    sector = min(sd for sd, _, _ in te)
    out = {}
    for torque in sorted({t for _, t, _ in te}):
        positions = sorted(k for sd, t, k in te if sd == full and t == torque)
        if not positions or any((sector, torque, k) not in te for k in positions):
            raise ReferenceError(f"{path}: {torque:g} N m: the sector's TE missing at a "
                                 "position of the whole gears'")
        diff = [te[(full, torque, k)] - te[(sector, torque, k)] for k in positions]
        mean = sum(diff) / len(diff)
        out[torque] = (mean, max(abs(d - mean) for d in diff))
    return out


def with_sector_correction(reference: Reference, correction: dict[float, tuple[float, float]]) -> Reference:
    """A sector reference with its mean corrected to whole gears (read_sector), every torque of
    the reference needing the study's; the other quantities as they are."""
    if reference.kind != "3d" or not correction:
        return reference
    missing = [t for t in reference.torques if t not in correction]
    if missing:
        raise ReferenceError(f"{reference.path}: the sector study has no torque "
                             f"{', '.join(f'{t:g}' for t in missing)} N m")
    values = {key: dict(v) for key, v in reference.values.items()}
    for (model, torque), v in values.items():
        v["mean"] += correction[torque][0]
    return Reference(reference.scene, reference.path, reference.n_positions, values, reference.kind,
                     reference.models, {t: correction[t] for t in reference.torques})


def positions_path(reference_dir: pathlib.Path, scene_name: str, kind: str = "2d") -> pathlib.Path:
    return pathlib.Path(reference_dir) / f"{scene_name}.{_FILE_STEM[kind]}.te.csv"


def read_positions(path: pathlib.Path, n_positions: int) -> dict[tuple[str, float], list[float]]:
    """(model, torque) -> TE at positions 0..n-1 of the base cases (case "base" where the file
    has the column, else mesh level 0; the rows with n_positions = n); {} when the file does not
    exist."""
    path = pathlib.Path(path)
    if not path.is_file():
        return {}
    curves: dict[tuple[str, float], dict[int, float]] = {}
    def parse(row):
        # 3-D files name their base case (whatever its mesh level); 2-D ones: level 0
        if row.get("case", "base") != "base" or ("case" not in row and row["mesh_level"] != "0"):
            return None
        return (row["model"], float(row["torque_Nm"])), int(row["position"]), float(row["te_m"])

    for key, k, te in _rows(path, n_positions, parse):
        curves.setdefault(key, {})[k] = te
    out = {}
    for key, by_position in curves.items():
        _require_positions(path, f"{key[0]} at {key[1]:g} N m", by_position, n_positions)
        out[key] = [by_position[k] for k in range(n_positions)]
    return out


def position_error(curves: dict[tuple[str, float], list[float]], torque: float, values,
                   models: tuple[str, ...], quantity: str, unit: str) -> dict | None:
    """A quantity compared position by position with the band of the models' curves at each
    position: at the position where the product lies farthest outside, the product's and the
    models' values and the signed distance; against each model the worst relative error over
    the positions. None without every model's curve at this torque."""
    if any((m, torque) not in curves for m in models):
        return None
    worst = None
    for k, value in enumerate(values):
        here = [curves[(m, torque)][k] for m in models]
        d = band_error(value, min(here), max(here))
        if worst is None or abs(d) > abs(worst[0]):
            worst = (d, k)
    d, k = worst
    row = {"quantity": quantity, "unit": unit, "product": float(values[k]), "band_error": d}
    for m in models:
        ref = curves[(m, torque)]
        row[column(m)] = ref[k]
        row[f"error_{column(m)}"] = max((relative_error(v, r) for v, r in zip(values, ref)),
                                        key=abs)
    return row


def curve_error(positions: dict[tuple[str, float], list[float]], torque: float,
                te, models: tuple[str, ...] = MODELS) -> dict | None:
    """The "curve" row of a product TE at the reference's positions (position_error)."""
    return position_error(positions, torque, te, models, CURVE, "m")


def pairs_path(reference_dir: pathlib.Path, scene_name: str) -> pathlib.Path:
    return pathlib.Path(reference_dir) / f"{scene_name}.reference_fe.pairs.csv"


def read_pairs(path: pathlib.Path, n_positions: int) -> tuple[dict, dict]:
    """From the per-tooth contact forces (reference_fe/README.md, "Load share and peak line
    load"): (model, torque) -> per position 0..n-1 the most loaded tooth's share of the total
    contact force, and its line load (N/m); ({}, {}) when the file does not exist."""
    path = pathlib.Path(path)
    if not path.is_file():
        return {}, {}
    teeth: dict[tuple[str, float, int], list[tuple[float, float]]] = {}
    def parse(row):
        return ((row["model"], float(row["torque_Nm"]), int(row["position"])),
                (float(row["force_N"]), float(row["line_load_N_per_m"])))

    for key, force_and_load in _rows(path, n_positions, parse):
        teeth.setdefault(key, []).append(force_and_load)
    shares: dict[tuple[str, float], dict[int, float]] = {}
    loads: dict[tuple[str, float], dict[int, float]] = {}
    for (model, torque, k), forces in teeth.items():
        total = sum(f for f, _ in forces)
        if not total > 0:
            raise ReferenceError(f"{path}: {model} at {torque:g} N m, position {k}: no contact "
                                 "force; allowed: a loaded position")
        top = max(forces)
        shares.setdefault((model, torque), {})[k] = top[0] / total
        loads.setdefault((model, torque), {})[k] = top[1]
    for by_position in (shares, loads):
        for key, values in by_position.items():
            _require_positions(path, f"{key[0]} at {key[1]:g} N m", values, n_positions)
    return ({key: [v[k] for k in range(n_positions)] for key, v in shares.items()},
            {key: [v[k] for k in range(n_positions)] for key, v in loads.items()})


def pair_errors(shares: dict, loads: dict, torque: float, product_shares, product_loads,
                models: tuple[str, ...] = MODELS) -> list[dict]:
    """The "load_share" row (the most loaded pair's share, position by position) and the
    "pair_line_load" row (that pair's force over the face width, the largest over the
    positions, against the band of the models' largest); [] without the reference's per-tooth
    forces at this torque."""
    share = position_error(shares, torque, product_shares, models, LOAD_SHARE, "1")
    if share is None or any((m, torque) not in loads for m in models):
        return []
    peak = {m: max(loads[(m, torque)]) for m in models}
    product = float(max(product_loads))
    row = {"quantity": PAIR_LINE_LOAD, "unit": "N/m", "product": product,
           "band_error": band_error(product, min(peak.values()), max(peak.values()))}
    for m in models:
        row[column(m)] = peak[m]
        row[f"error_{column(m)}"] = relative_error(product, peak[m])
    return [share, row]


def column(model: str) -> str:
    """A model's name in the error rows: the 2-D model's own, "fe3d" for any 3-D model."""
    return "fe3d" if model.startswith(MODEL_3D_PREFIX) else model


def relative_error(value: float, reference: float) -> float:
    """(value - reference) / reference."""
    return (value - reference) / reference


def band_error(value: float, low: float, high: float) -> float:
    """0 inside [low, high], else the signed distance to the nearer edge relative to it."""
    if value < low:
        return relative_error(value, low)
    if value > high:
        return relative_error(value, high)
    return 0.0


def errors(reference: Reference, torque: float, product: dict[str, float]) -> list[dict]:
    """One row per quantity: the product's value, both models', the band error and the error
    against each model."""
    rows = []
    for q in QUANTITIES:
        low, high = reference.band(torque, q)
        row = {"quantity": q, "unit": "m", "product": product[q],
               "band_error": band_error(product[q], low, high)}
        for m in reference.models:
            row[column(m)] = reference.values[(m, torque)][q]
            row[f"error_{column(m)}"] = relative_error(product[q], reference.values[(m, torque)][q])
        rows.append(row)
    return rows


def lineload_path(reference_dir: pathlib.Path, scene_name: str) -> pathlib.Path:
    return pathlib.Path(reference_dir) / f"{scene_name}.reference_fe3d.lineload.csv"


def read_lineload(path: pathlib.Path, n_positions: int) -> dict[tuple[int, float], list[float]]:
    """From the 3-D line load across the face: (bin count, torque) -> per position 0..n-1 the
    largest line load (N/m) over the teeth and bins; {} when the file does not exist."""
    path = pathlib.Path(path)
    if not path.is_file():
        return {}
    peaks: dict[tuple[int, float], dict[int, float]] = {}
    def parse(row):
        q = float(row["line_load_N_per_m"])
        if not (math.isfinite(q) and q >= 0):
            raise ValueError(f"line_load_N_per_m = {q}; allowed: finite, >= 0")
        return (int(row["bins"]), float(row["torque_Nm"])), int(row["position"]), q

    for key, k, q in _rows(path, n_positions, parse):
        by_position = peaks.setdefault(key, {})
        by_position[k] = max(by_position.get(k, 0.0), q)
    for (bins, torque), by_position in peaks.items():
        _require_positions(path, f"{bins} bins at {torque:g} N m", by_position, n_positions)
        unloaded = [k for k, q in by_position.items() if not q > 0]
        if unloaded:
            raise ReferenceError(f"{path}: {bins} bins at {torque:g} N m, position(s) {unloaded}: "
                                 "no contact force; allowed: a loaded position")
    return {key: [v[k] for k in range(n_positions)] for key, v in peaks.items()}


def peak_line_load_error(peaks: dict[tuple[int, float], list[float]], torque: float, slices: int,
                         product_loads) -> dict | None:
    """The "peak_line_load" row: the product's largest slice line load over the positions
    (mesh.max_line_load) against the 3-D reference's largest bin line load over the positions at
    `slices` bins; None without that bin count and torque in the reference."""
    if (slices, torque) not in peaks:
        return None
    reference = max(peaks[(slices, torque)])
    product = float(max(product_loads))
    error = relative_error(product, reference)
    return {"quantity": PEAK_LINE_LOAD, "unit": "N/m", "product": product, "band_error": error,
            "fe3d": reference, "error_fe3d": error}
