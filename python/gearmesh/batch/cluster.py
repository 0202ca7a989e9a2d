"""The Dask side of a batch (docs/batch.md): a client of a running scheduler (`--scheduler
ADDRESS`), or of a local cluster with one single-threaded worker process per core — the same code
path either way — and the input files shipped to the workers by content (SHA-256): uploaded
through the scheduler, or copied once into a folder every worker reads (`--shared DIR`).
"""
from __future__ import annotations

import contextlib
import os
import pathlib
import shutil
import tempfile

from gearmesh.compliance import tool_hash as file_hash

CONNECT_TIMEOUT_S = 10.0
WORKER_FILES = "gearmesh-worker-files"  # under the worker's temporary folder (uploaded files)


class ClusterError(RuntimeError):
    """The cluster cannot be used; the message names the option and what is allowed."""


@contextlib.contextmanager
def connect(scheduler: str | None = None, workers: int | None = None,
            timeout: float = CONNECT_TIMEOUT_S):
    """A distributed.Client: of `scheduler` (e.g. tcp://host:8786) when given, else of a local
    cluster of `workers` processes (default: one per core) with one thread each on 127.0.0.1."""
    from distributed import Client, LocalCluster

    cluster = None
    if scheduler:
        try:
            client = Client(scheduler, timeout=timeout)
        except ValueError as exc:
            raise ClusterError(f"--scheduler {scheduler}: not a scheduler address ({exc}); "
                               "allowed: PROTOCOL://HOST:PORT, e.g. tcp://host:8786") from None
        except (OSError, TimeoutError) as exc:
            raise ClusterError(f"--scheduler {scheduler}: no Dask scheduler answered within "
                               f"{timeout:g} s ({type(exc).__name__}: {exc}); allowed: the "
                               "address of a running scheduler, e.g. tcp://host:8786") from None
        try:
            client.wait_for_workers(1, timeout=timeout)
        except (OSError, TimeoutError) as exc:
            client.close()
            raise ClusterError(f"--scheduler {scheduler}: the scheduler has no worker after "
                               f"{timeout:g} s; start at least one (dask worker {scheduler})"
                               ) from exc
    else:
        n = (os.cpu_count() or 1) if workers is None else workers
        if not 1 <= n <= 1024:
            raise ClusterError(f"--jobs {n}: allowed range [1, 1024] local workers")
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                               host="127.0.0.1", dashboard_address=None)
        client = Client(cluster)
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


class Shipper:
    """Input files for the workers, each once by content: `source(path)` is the (sha256, what a
    task receives) pair, where a task receives a Dask future of the file's bytes (uploaded) or the
    path of its copy under `shared` (a folder every worker can read at the same path)."""

    def __init__(self, client, shared: pathlib.Path | None = None):
        self.client = client
        self.shared = pathlib.Path(shared) if shared is not None else None
        if self.shared is not None and not self.shared.is_dir():
            raise ClusterError(f"--shared {self.shared}: not a folder; allowed: an existing "
                               "folder that every worker reads at the same path")
        self._sources: dict[str, object] = {}

    def source(self, path: pathlib.Path) -> tuple[str, object]:
        path = pathlib.Path(path)
        sha = file_hash(path)
        if sha not in self._sources:
            if self.shared is not None:
                target = self.shared / f"{sha}{path.suffix}"
                if not target.is_file():
                    tmp = target.with_name(target.name + f".{os.getpid()}.part")
                    shutil.copyfile(path, tmp)
                    os.replace(tmp, target)
                self._sources[sha] = str(target)
            else:
                self._sources[sha] = self.client.scatter(path.read_bytes(), hash=False)
        return sha, self._sources[sha]


def local_file(sha: str, suffix: str, source: bytes | str) -> pathlib.Path:
    """On a worker: the file of `source`, the bytes written once under the worker's temporary
    folder by their hash (atomically: workers of one machine share it), or the shared path."""
    if isinstance(source, str):
        return pathlib.Path(source)
    folder = pathlib.Path(tempfile.gettempdir()) / WORKER_FILES
    target = folder / f"{sha}{suffix}"
    if not target.is_file():
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, suffix=".part")
        with os.fdopen(fd, "wb") as fh:
            fh.write(source)
        os.replace(tmp, target)
    return target
