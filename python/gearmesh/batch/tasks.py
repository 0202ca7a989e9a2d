"""A batch's tasks on a Dask cluster (docs/batch.md): level 5's compliance databases, one task per
content hash of their inputs (compliance.cache_key, also the task's key, so no two workers build
the same database), then one task per case that needs no finished result. A task that fails is
retried once (also on another worker when its worker died), then reported; each result is written
to out/cases/<case id>.json as it arrives, the case id being a hash of everything the case's
result depends on, so that a batch run again skips what it finished.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import pathlib

from tqdm import tqdm

from gearmesh import compliance
from gearmesh.batch import cluster
from gearmesh.batch.cases import Case, run_case
from gearmesh.paths import COMPLIANCE_TOOL_ROUTE

RETRIES = 1


def case_id(case: Case, fmu_sha: str, files: dict[str, tuple]) -> str:
    """SHA-256 of the FMU's and the resources' contents (database: its cache key), the scene's
    parameters and run settings, the torque, overrides and tags."""
    scene = case.scene
    text = json.dumps({"fmu": fmu_sha, "scene": scene.name, "parameters": scene.parameters,
                       "run": scene.run, "files": {n: f[0] for n, f in sorted(files.items())},
                       "torque": case.torque, "overrides": case.overrides, "tags": case.tags},
                      sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def label(case: Case) -> str:
    """The case as a person reads it: scene, torque, tags, overrides."""
    extra = [f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
             for k, v in (*case.tags, *case.overrides)]
    return " ".join([case.scene.name, f"{case.torque:g} N m", *extra])


def build_database(scene, gear: int, shared_cache: str | None) -> bytes | str:
    """On a worker: gear `gear`'s database (compliance.build_gear, cached); its path in the
    shared cache, or its bytes when the workers share no folder."""
    cache = pathlib.Path(shared_cache) if shared_cache else None
    built = compliance.build_gear(scene, gear, cache=cache, progress=False)
    return str(built.path) if shared_cache else built.path.read_bytes()


def run_shipped(case: Case, fmu: tuple, files: dict[str, tuple]) -> list[dict]:
    """On a worker: the case with the FMU and resources as local files (cluster.local_file)."""
    fmu_path = cluster.local_file(*fmu)
    resources = {name: cluster.local_file(*f) for name, f in files.items()}
    scene = dataclasses.replace(case.scene, resources=resources)
    return run_case(dataclasses.replace(case, scene=scene), str(fmu_path))


def _scene_files(client, ship: cluster.Shipper, scene, shared, builds: dict) -> tuple:
    """(scene with its databases named, {resource name: (sha, suffix, source)})."""
    files = {name: (*_source(ship, path),) for name, path in scene.resources.items()}
    parameters = dict(scene.parameters)
    for gear in compliance.needs_build(scene):
        key = compliance.cache_key(scene, gear, compliance.default_tool())
        if key not in builds:
            cache = str(shared / "compliance_cache") if shared is not None else None
            if cache:
                pathlib.Path(cache).mkdir(exist_ok=True)
            builds[key] = client.submit(build_database, scene, gear, cache, key=f"gcdb-{key}",
                                        retries=RETRIES)
        files[f"gear{gear}.gcdb"] = (key, ".gcdb", builds[key])
        parameters[f"gear{gear}.compliance"] = f"gear{gear}.gcdb"
    return dataclasses.replace(scene, parameters=parameters), files


def _source(ship: cluster.Shipper, path: pathlib.Path) -> tuple:
    sha, source = ship.source(path)
    return sha, pathlib.Path(path).suffix, source


def run(client, cases: list[Case], generic_fmu: pathlib.Path, out: pathlib.Path,
        shared: pathlib.Path | None = None):
    """Run the cases that have no result in out/cases/; returns (rows of every finished case,
    cases run now, cases skipped, {case label: error})."""
    from distributed import as_completed

    if not generic_fmu.is_file():
        raise cluster.ClusterError(f"--fmu {generic_fmu}: not a file; build the 'fmu' target")
    if any(compliance.needs_build(c.scene) for c in cases):
        tool = compliance.default_tool()
        if not tool.is_file():
            raise compliance.ComplianceError(f"{tool}: compliance_tool not found: {COMPLIANCE_TOOL_ROUTE}")
    done = out / "cases"
    done.mkdir(parents=True, exist_ok=True)
    ship = cluster.Shipper(client, shared)
    fmu = _source(ship, generic_fmu)
    scenes: dict[int, tuple] = {}
    builds: dict[str, object] = {}
    finished, todo, queued = [], [], set()
    for case in cases:
        if id(case.scene) not in scenes:
            scenes[id(case.scene)] = _scene_files(client, ship, case.scene, shared, builds)
        scene, files = scenes[id(case.scene)]
        ident = case_id(dataclasses.replace(case, scene=scene), fmu[0], files)
        if (done / f"{ident}.json").is_file():
            finished.append(ident)
        elif ident not in queued:
            queued.add(ident)
            todo.append((ident, dataclasses.replace(case, scene=scene), files))
    skipped = len(finished)
    futures = {}
    for ident, case, files in todo:
        future = client.submit(run_shipped, case, fmu, files, key=f"case-{ident}",
                               retries=RETRIES)
        futures[future] = (ident, case)
    errors = {}
    with tqdm(total=skipped + len(todo), initial=skipped, desc="batch", unit="case") as bar:
        for future in as_completed(futures):
            ident, case = futures[future]
            try:
                # a result lost with its worker after the task finished is computed again: wait
                # for it rather than read the status of the moment ("lost")
                rows = future.result()
            except Exception as exc:  # the case's own error, after its retry
                errors[label(case)] = f"{type(exc).__name__}: {exc}"
                bar.write(f"gearmesh: case {label(case)} failed after {RETRIES} retry: "
                          f"{errors[label(case)]}")
            else:
                _write_json(done / f"{ident}.json", {"case": label(case), "rows": rows})
                finished.append(ident)
            bar.update()
            future.release()
    rows = []
    for ident in finished:
        rows += json.loads((done / f"{ident}.json").read_text())["rows"]
    return rows, len(todo) - len(errors), skipped, errors


def _write_json(path: pathlib.Path, data) -> None:
    """Atomically: an interrupted write leaves no half file that would count as finished."""
    tmp = path.with_name(path.name + f".{os.getpid()}.part")
    tmp.write_text(json.dumps(data))
    os.replace(tmp, path)
