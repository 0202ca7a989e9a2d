"""Batches on a Dask cluster (issue 17): a scheduler and two single-threaded workers started as
separate processes on 127.0.0.1; every result compared bit for bit with a plain serial run of the
same cases in this process (batch.run_in_process, no Dask)."""
from __future__ import annotations

import contextlib
import csv
import filecmp
import json
import os
import pathlib
import signal
import subprocess
import sys
import threading
import time
import uuid

import cloudpickle
import numpy as np
import pytest
from distributed import Client
from distributed.diagnostics.plugin import SchedulerPlugin

from gearmesh import compliance
from gearmesh.batch import run as batch, tasks as batch_tasks, cluster
from gearmesh.scene import load_scene
from test_fe_scenes import PAIR
from conftest import REPO

SCENES = REPO / "scenarios"
DASK = pathlib.Path(sys.executable).with_name("dask")
FAKE_TOOL = """#!{python}
# stands in for compliance_tool: logs its run, writes its arguments as the 'database'; with
# --check (scene validation) every body fits
import sys
args = sys.argv[1:]
if "--check" in args:
    sys.exit(0)
out = args[args.index("--out") + 1]
with open({log!r}, "a") as fh:
    fh.write(" ".join(args[args.index("--gear"):args.index("--gear") + 2]) + "\\n")
with open(out, "w") as fh:
    fh.write("fake database " + " ".join(a for a in args if a != out))
print("compliance_tool: nodes=1 total_s=0.0 peak_rss_MiB=1")
"""


def _start(tmp: pathlib.Path, env: dict) -> tuple[str, list[subprocess.Popen]]:
    """A scheduler and two workers (no nanny: each worker is the process we can kill)."""
    procs = []
    sched_file = tmp / "scheduler.json"
    log = open(tmp / "cluster.log", "w")
    procs.append(subprocess.Popen([str(DASK), "scheduler", "--host", "127.0.0.1", "--port", "0",
                                   "--no-dashboard", "--scheduler-file", str(sched_file)],
                                  stdout=log, stderr=log, env=env))
    deadline = time.monotonic() + 60
    while not sched_file.is_file() and time.monotonic() < deadline:
        time.sleep(0.1)
    address = json.loads(sched_file.read_text())["address"]
    for i in range(2):
        procs.append(subprocess.Popen([str(DASK), "worker", address, "--nthreads", "1",
                                       "--no-nanny", "--no-dashboard", "--host", "127.0.0.1",
                                       "--name", f"w{i}", "--local-directory", str(tmp / f"w{i}")],
                                      stdout=log, stderr=log, env=env))
    with Client(address, timeout=30) as client:
        client.wait_for_workers(2, timeout=60)
    return address, procs


def _stop(procs):
    """Kill the processes we started (a worker's graceful close waits for its scheduler)."""
    for p in reversed(procs):
        if p.poll() is None:
            p.kill()
    for p in procs:
        p.wait()


def _worker(client, name: str) -> str:
    """The address of the worker started as `name` (w0, w1)."""
    return next(a for a, w in client.scheduler_info()["workers"].items() if w["name"] == name)


def _held(client, worker: str) -> list[str]:
    """The case tasks the scheduler has given `worker` and not yet had back (Client.processing)."""
    return [str(k) for k in client.processing([worker]).get(worker, []) if str(k).startswith("case-")]


class CaseRuns(SchedulerPlugin):
    """On the scheduler (a scheduler plugin, Dask's public interface): each time a case task
    leaves `processing`, where to, as an event of its own topic (Client.get_events): "memory" a
    result, "erred" failed for good, anything else a run that ended without a result (failed and
    retried, or its worker gone)."""

    def __init__(self):
        self.name = self.topic = f"gearmesh-test-case-runs-{uuid.uuid4().hex}"

    async def start(self, scheduler):
        self.scheduler = scheduler

    def transition(self, key, start, finish, *args, **kwargs):
        if start == "processing" and str(key).startswith("case-"):
            self.scheduler.log_event(self.topic, (str(key), finish))


@contextlib.contextmanager
def _case_runs(client):
    """[(case task key, where it went from processing)] of the batches run inside, in order;
    filled on leaving the block."""
    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # the scheduler cannot import us
    plugin = CaseRuns()
    client.register_plugin(plugin)
    runs = []
    try:
        yield runs
    finally:
        runs += [tuple(msg) for _, msg in client.get_events(plugin.topic)]
        client.unregister_scheduler_plugin(plugin.name)


def _ends(runs, key) -> list[str]:
    return [to for k, to in runs if k == key]


@pytest.fixture(scope="module")
def fake_tool(tmp_path_factory):
    folder = tmp_path_factory.mktemp("tool")
    tool = folder / "compliance_tool"
    tool.write_text(FAKE_TOOL.format(python=sys.executable, log=str(folder / "runs.log")))
    tool.chmod(0o755)
    return tool, folder / "runs.log"


@pytest.fixture(scope="module")
def dask_cluster(tmp_path_factory):
    """The scheduler's address, the processes [scheduler, worker 0, worker 1] and the workers'
    compliance cache (their own, not this process's); torn down after the module."""
    tmp = tmp_path_factory.mktemp("cluster")
    env = {**os.environ, compliance.CACHE_ENV: str(tmp / "worker_cache")}
    procs = []
    try:
        address, procs = _start(tmp, env)
        yield address, procs, tmp / "worker_cache"
    finally:
        _stop(procs)


@pytest.fixture(scope="module")
def cases():
    scene = load_scene(SCENES / "paper_setB_P1P2.toml")
    return batch.expand([scene], [100.0, 200.0, 300.0, 350.0],
                        {"model.friction_coefficient": [0.3, 0.4]})


@pytest.fixture(scope="module")
def serial(cases, fmu_path, tmp_path_factory):
    """The same cases run one after the other in this process, written the same way."""
    out = tmp_path_factory.mktemp("serial")
    batch.write_outputs(batch.run_in_process(cases, fmu_path), cases, out)
    return out


def _same_as_serial(out: pathlib.Path, serial: pathlib.Path, n_cases: int):
    for name in ("batch_te.csv", "batch_summary.csv"):
        assert filecmp.cmp(out / name, serial / name, shallow=False), name
    assert sum(1 for _ in (out / "batch_summary.csv").open()) - 1 == n_cases


def test_cluster_results_equal_a_serial_run_uploaded_and_shared(dask_cluster, cases, serial,
                                                                fmu_path, tmp_path):
    address, *_ = dask_cluster
    up = batch.run_batch(cases, fmu_path, tmp_path / "up", scheduler=address)
    assert (up.ran, up.skipped, up.errors) == (len(cases), 0, {})
    _same_as_serial(tmp_path / "up", serial, len(cases))
    shared = tmp_path / "shared"
    shared.mkdir()
    sh = batch.run_batch(cases, fmu_path, tmp_path / "sh", scheduler=address, shared=shared)
    assert sh.errors == {}
    _same_as_serial(tmp_path / "sh", serial, len(cases))
    # the FMU went to the shared folder once, by content
    assert [p.suffix for p in shared.iterdir()] == [".fmu"]


def test_a_failing_case_is_reported_while_the_others_finish(dask_cluster, cases, fmu_path,
                                                           tmp_path):
    address, *_ = dask_cluster
    bad = batch.Case(cases[0].scene, 100.0, (("model.friction_coefficient", -1.0),))
    with Client(address) as client, _case_runs(client) as runs:
        result = batch.run_batch([*cases[:2], bad], fmu_path, tmp_path, scheduler=address)
    assert list(result.errors) == [batch_tasks.label(bad)]
    assert "model.friction_coefficient" in result.errors[batch_tasks.label(bad)]
    assert result.ran == 2 and len(result.summary_rows) == 2
    assert "friction_coefficient=-1" in (tmp_path / "batch_errors.csv").read_text()
    # the scheduler's record: the failed case was run twice (one retry), the others once
    erred = [k for k, to in runs if to == "erred"]
    assert len(erred) == 1, runs
    ends = _ends(runs, erred[0])
    assert len(ends) == 2 and ends[0] not in ("memory", "erred") and ends[1] == "erred", runs
    others = {k for k, _ in runs} - set(erred)
    assert len(others) == 2 and all(_ends(runs, k) == ["memory"] for k in others), runs


def test_resume_after_an_interrupt_skips_the_finished_cases(dask_cluster, cases, serial,
                                                           fmu_path, tmp_path):
    """The batch command killed (SIGKILL) mid-batch, then run again. Mid-batch by construction,
    not by timing: worker 1 is stopped (SIGSTOP) before the first run, so the cases the scheduler
    gives it cannot finish; the kill comes once a first result is kept and worker 1 holds a case.
    With a shared folder (--shared): uploaded files could sit on the stopped worker."""
    address, procs, _ = dask_cluster
    shared = tmp_path / "shared"
    shared.mkdir()
    command = [sys.executable, "-m", "gearmesh", "batch", str(SCENES / "paper_setB_P1P2.toml"),
               "--torques", "100", "200", "300", "350",
               "--vary", "model.friction_coefficient=0.3,0.4",
               "--fmu", str(fmu_path), "--out", str(tmp_path), "--scheduler", address,
               "--shared", str(shared)]
    with Client(address) as client:
        w1 = _worker(client, "w1")
        procs[2].send_signal(signal.SIGSTOP)
        try:
            proc = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            try:
                deadline = time.monotonic() + 120
                while not (list((tmp_path / "cases").glob("*.json")) and (held := _held(client, w1))):
                    assert proc.poll() is None, "the batch ended before any result was kept"
                    assert time.monotonic() < deadline, "no result kept, or worker 1 given no case"
                    time.sleep(0.02)
                proc.send_signal(signal.SIGKILL)  # the hardest interrupt: no clean-up at all
            finally:
                proc.kill()
                proc.wait()
        finally:
            procs[2].send_signal(signal.SIGCONT)
    assert proc.returncode == -signal.SIGKILL
    kept = len(list((tmp_path / "cases").glob("*.json")))
    assert 1 <= kept <= len(cases) - len(held)  # worker 1's cases were not finished
    result = batch.run_batch(cases, fmu_path, tmp_path, scheduler=address, shared=shared)
    assert (result.skipped, result.ran, result.errors) == (kept, len(cases) - kept, {})
    _same_as_serial(tmp_path, serial, len(cases))


def _set_worker_env(name, value):
    """Run on the workers (client.run; sent by value: the workers cannot import the tests)."""
    if value is None:
        os.environ.pop(name, None)
    else:
        os.environ[name] = value


def test_fe_databases_build_once_per_content_hash(dask_cluster, fake_tool, monkeypatch, tmp_path):
    tool, log = fake_tool
    monkeypatch.setenv(compliance.TOOL_ENV, str(tool))
    address, *_ = dask_cluster
    # set A's gears are equal: one database for both, also across two copies of the scene
    scenes = [load_scene(SCENES / "fe" / "paper_setA_3U4U_fe.toml") for _ in range(2)]
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    with Client(address) as client:
        client.run(_set_worker_env, compliance.TOOL_ENV, str(tool))
        try:
            ship = cluster.Shipper(client)
            builds = {}
            files = [batch_tasks._scene_files(client, ship, s, None, builds)[1] for s in scenes]
            assert len(builds) == 1
            data = client.gather(list(builds.values()))[0]
        finally:
            client.run(_set_worker_env, compliance.TOOL_ENV, None)
    assert data.startswith(b"fake database ") and b" --gear 1 " in data
    assert files[0]["gear1.gcdb"][0] == files[1]["gear2.gcdb"][0] == next(iter(builds))
    assert log.read_text().splitlines() == ["--gear 1"]  # one tool run in all


# test_fe_scenes.py's small coarse pair (equal gears: one database), a short sweep
SMALL_FE = PAIR + "[run]\npoints_per_pitch = 10\nte_pitches = 2\n"


def test_level_5_builds_its_database_on_a_worker_and_matches_a_serial_run(
        dask_cluster, fmu_path, tmp_path, monkeypatch):
    """The real compliance_tool on the small coarse pair: one database, built on a worker. Level
    5 is not bit for bit reproducible across processes (docs/batch.md, "Batches": in the full
    suite the serial run on the worker's own database moved the TE by 5e-13 relative, in a run
    of this file alone not at all), so the serial runs, on that database and on one built in this
    process, are compared to 1e-9 of the TE."""
    address, _, worker_cache = dask_cluster
    path = tmp_path / "small_fe.toml"
    path.write_text(SMALL_FE)
    cases = batch.expand([load_scene(path)], [20.0, 40.0], {})
    key = compliance.cache_key(cases[0].scene, 1, compliance.default_tool())
    assert key == compliance.cache_key(cases[0].scene, 2, compliance.default_tool())
    before = set(worker_cache.glob("*.gcdb"))
    result = batch.run_batch(cases, fmu_path, tmp_path / "dask", scheduler=address)
    assert result.errors == {} and result.ran == 2
    assert set(worker_cache.glob("*.gcdb")) - before == {worker_cache / f"{key}.gcdb"}
    te = np.array([float(r["te_m"]) for r in csv.DictReader((tmp_path / "dask" / "batch_te.csv").open())])
    assert len(te) == 2 * 20 and te.min() > 1e-6
    for cache in (worker_cache, tmp_path / "own_cache"):
        monkeypatch.setenv(compliance.CACHE_ENV, str(cache))
        serial = tmp_path / cache.name
        serial.mkdir(exist_ok=True)
        batch.write_outputs(batch.run_in_process(cases, fmu_path), cases, serial)
        te_serial = np.array([float(r["te_m"])
                              for r in csv.DictReader((serial / "batch_te.csv").open())])
        assert np.abs(te_serial - te).max() < 1e-9 * te.max(), cache.name
    assert len(list((tmp_path / "own_cache").glob("*.gcdb"))) == 1


def test_a_worker_killed_mid_batch_still_yields_every_result(cases, serial, fmu_path, tmp_path):
    """Worker 0 is killed while it runs a case: Client.call_stack shows a case executing there
    (and one on worker 1, which so holds the uploaded files too), the worker is stopped at once
    (SIGSTOP: what it holds can no longer finish), the cases it holds are read
    (Client.processing), and it is killed. The scheduler's record (CaseRuns) must show a case it
    held ending without a result, then computed again; every result is there."""
    address, procs = _start(tmp_path, dict(os.environ))
    held = []
    try:
        with Client(address) as client, _case_runs(client) as runs:
            w0, w1 = _worker(client, "w0"), _worker(client, "w1")
            outcome = {}
            thread = threading.Thread(target=lambda: outcome.update(result=batch.run_batch(
                cases, fmu_path, tmp_path / "out", scheduler=address)))
            thread.start()
            deadline = time.monotonic() + 120
            while thread.is_alive() and time.monotonic() < deadline:
                stacks = client.call_stack()
                if all(any(str(k).startswith("case-") for k in stacks.get(w, {})) for w in (w0, w1)):
                    procs[1].send_signal(signal.SIGSTOP)
                    held = _held(client, w0)
                    procs[1].send_signal(signal.SIGKILL)
                    break
                time.sleep(0.005)
            thread.join()
    finally:
        _stop(procs)
    assert held, "worker 0 was not killed while it ran a case"
    assert procs[1].returncode == -signal.SIGKILL
    lost = [k for k in held if _ends(runs, k)[0] != "memory"]
    assert lost, f"every case worker 0 held had finished before it was killed: {runs}"
    assert all(_ends(runs, k)[-1] == "memory" for k in held), runs
    result = outcome["result"]
    assert result.errors == {} and result.ran == len(cases)
    assert len(list((tmp_path / "out" / "cases").glob("*.json"))) == len(cases)
    _same_as_serial(tmp_path / "out", serial, len(cases))


def test_unreachable_scheduler_and_bad_jobs_are_named():
    import socket

    with socket.socket() as s:  # a free port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(cluster.ClusterError, match=rf"--scheduler tcp://127.0.0.1:{port}: no Dask "
                       r"scheduler answered within 1 s .*allowed: the address of a running"):
        with cluster.connect(f"tcp://127.0.0.1:{port}", timeout=1):
            pass
    with pytest.raises(cluster.ClusterError, match=r"--jobs 0: allowed range \[1, 1024\]"):
        with cluster.connect(None, 0):
            pass


@pytest.mark.parametrize("argv, needle", [
    (["--scheduler", "foo"], "--scheduler foo: not a scheduler address"),
    (["--jobs", "100000"], "--jobs 100000: allowed range [1, 1024] local workers"),
    (["--vary", "model.frictoin_coefficient=0.3"], "--vary model.frictoin_coefficient: unknown "
     "parameter 'model.frictoin_coefficient' (did you mean model.friction_coefficient"),
])
def test_bad_batch_input_is_named_without_traceback(argv, needle, fmu_path, tmp_path, capsys):
    from gearmesh import cli

    assert cli.main(["batch", str(SCENES / "paper_setB_P1P2.toml"), "--fmu", str(fmu_path),
                     "--out", str(tmp_path), *argv]) == 2
    err = capsys.readouterr().err
    assert needle in err and "Traceback" not in err
