"""The FE reference of a scene (reference_fe/README.md, "Outputs") and the errors against it.

`<scene>.reference_fe.summary.csv` holds, per model (plane_strain, plane_stress) and torque, the
mean, peak-to-peak and mesh orders 1-3 of the loaded TE over one pitch. The 3-D truth lies between
the two models: the band [min, max] of the two values of each quantity. The error of a product
value against the band is 0 inside it, else the signed distance to the nearer edge relative to
that edge; against one model it is (product - model) / model.

The band of a peak-to-peak or an order amplitude is not a bound on the 3-D truth: a curve that
lies between the two models at every position can have a larger p-p than either (stiff like
plane strain where two pairs carry, soft like plane stress where one does). So the TE curve is
also compared position by position (`<scene>.reference_fe.te.csv`): the quantity "curve" is the
worst signed distance of the product's TE to the band of the two models at the same position.
"""
from __future__ import annotations

import csv
import math
import pathlib
from dataclasses import dataclass

MODELS = ("plane_stress", "plane_strain")
QUANTITIES = ("mean", "pp", "order1", "order2", "order3")  # the summary's <q>_te_m / <q>_m columns
CURVE = "curve"  # the TE position by position against the per-position band (te.csv)
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

    @property
    def torques(self) -> list[float]:
        return sorted({t for _, t in self.values})

    def band(self, torque: float, quantity: str) -> tuple[float, float]:
        a, b = (self.values[(m, torque)][quantity] for m in MODELS)
        return min(a, b), max(a, b)


def summary_path(reference_dir: pathlib.Path, scene_name: str) -> pathlib.Path:
    return pathlib.Path(reference_dir) / f"{scene_name}.reference_fe.summary.csv"


def read_summary(path: pathlib.Path) -> Reference:
    """Read a summary; lines starting with '#' are comments. Every torque must have both models
    and one n_positions for the whole file."""
    path = pathlib.Path(path)
    try:
        with path.open(newline="") as fh:
            rows = list(csv.DictReader(line for line in fh if not line.lstrip().startswith("#")))
    except OSError as exc:
        raise ReferenceError(f"{path}: cannot read the reference summary ({exc.strerror})") from exc
    if not rows:
        raise ReferenceError(f"{path}: no rows")
    missing = [c for c in _REQUIRED if c not in rows[0]]
    if missing:
        raise ReferenceError(f"{path}: missing column(s) {', '.join(missing)}; required: "
                             f"{', '.join(_REQUIRED)}")
    values: dict[tuple[str, float], dict[str, float]] = {}
    scenes, counts = set(), set()
    for line, row in enumerate(rows, start=2):
        if row["model"] not in MODELS:
            raise ReferenceError(f"{path}: row {line}: model = {row['model']!r}; allowed: "
                                 f"{', '.join(MODELS)}")
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
    if len(counts) != 1 or min(counts) < 4:
        raise ReferenceError(f"{path}: n_positions = {sorted(counts)}; allowed: one value >= 4")
    for model, torque in list(values):
        other = MODELS[1 - MODELS.index(model)]
        if (other, torque) not in values:
            raise ReferenceError(f"{path}: {model} at {torque:g} N m has no {other} row "
                                 "(the band needs both models)")
    return Reference(scenes.pop(), path, counts.pop(), values)


def positions_path(reference_dir: pathlib.Path, scene_name: str) -> pathlib.Path:
    return pathlib.Path(reference_dir) / f"{scene_name}.reference_fe.te.csv"


def read_positions(path: pathlib.Path, n_positions: int) -> dict[tuple[str, float], list[float]]:
    """(model, torque) -> TE at positions 0..n-1 of the base cases (mesh level 0, the file's
    default penalty: the rows with n_positions = n); {} when the file does not exist."""
    path = pathlib.Path(path)
    if not path.is_file():
        return {}
    curves: dict[tuple[str, float], dict[int, float]] = {}
    with path.open(newline="") as fh:
        for line, row in enumerate(csv.DictReader(l for l in fh if not l.lstrip().startswith("#")),
                                   start=2):
            try:
                if int(row["n_positions"]) != n_positions or row.get("mesh_level", "0") != "0":
                    continue
                key = (row["model"], float(row["torque_Nm"]))
                curves.setdefault(key, {})[int(row["position"])] = float(row["te_m"])
            except (KeyError, ValueError) as exc:
                raise ReferenceError(f"{path}: row {line}: {exc}") from exc
    out = {}
    for key, by_position in curves.items():
        if sorted(by_position) != list(range(n_positions)):
            raise ReferenceError(f"{path}: {key[0]} at {key[1]:g} N m has positions "
                                 f"{sorted(by_position)}; required: 0..{n_positions - 1}")
        out[key] = [by_position[k] for k in range(n_positions)]
    return out


def curve_error(positions: dict[tuple[str, float], list[float]], torque: float,
                te) -> dict | None:
    """The "curve" row of a product TE at the reference's positions: at the position where the
    TE lies farthest outside the band of the two models there, the product's and the models'
    values and the signed distance; against each model the worst relative error over the
    positions. None without both models' curves at this torque."""
    if any((m, torque) not in positions for m in MODELS):
        return None
    worst = None
    for k, value in enumerate(te):
        a, b = (positions[(m, torque)][k] for m in MODELS)
        d = band_error(value, min(a, b), max(a, b))
        if worst is None or abs(d) > abs(worst[0]):
            worst = (d, k)
    d, k = worst
    row = {"quantity": CURVE, "product_m": float(te[k]), "band_error": d}
    for m in MODELS:
        ref = positions[(m, torque)]
        row[f"{m}_m"] = ref[k]
        row[f"error_{m}"] = max((relative_error(v, r) for v, r in zip(te, ref)), key=abs)
    return row


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
        row = {"quantity": q, "product_m": product[q],
               "band_error": band_error(product[q], low, high)}
        for m in MODELS:
            row[f"{m}_m"] = reference.values[(m, torque)][q]
            row[f"error_{m}"] = relative_error(product[q], reference.values[(m, torque)][q])
        rows.append(row)
    return rows
