"""Where a study's tasks run, behind one interface: in this process, in a local process
pool, or on a dask.distributed cluster (a LocalCluster started here, or one joined at
``tcp://host:port``).

    with make_executor(workers=2) as ex:                 # or dask="local" / "tcp://..."
        for index, result in ex.map_unordered(fn, tasks):
            ...

Results come back in completion order, each with its task's index; everything a task
computes depends on the task alone (seeds included), never on which worker ran it or
when, so the same study gives the same bytes on every executor. Tasks must be top-level
functions of importable modules (dask workers import them by name).

Rendering in a worker: MuJoCo picks its GL backend when first imported, from
``MUJOCO_GL``. Local workers inherit the parent's environment, where the CLI has set
``MUJOCO_GL=egl``; the task functions also set it (``setdefault``) before anything
imports mujoco, which covers workers of a remote cluster started without it (EGL in
each worker process: mujoco issue #991, PR #2069; docs/NOTES.md, dask.distributed).
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Any

from rasc.errors import InputError

#: single-threaded numerical libraries in every worker: N workers use N cores, and a
#: result never depends on a library's thread count
THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def worker_environment() -> None:
    """What every worker process sets before its first task (idempotent)."""
    os.environ.setdefault("MUJOCO_GL", "egl")
    for var in THREAD_VARS:
        os.environ.setdefault(var, "1")


def _pool_worker_init() -> None:
    """A process-pool worker: :func:`worker_environment`, and Ctrl-C left to the parent
    (it reaches the whole process group; the parent stops the pool and says what it
    kept, a worker must not print a traceback of its own)."""
    import signal
    worker_environment()
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class Executor:
    """Runs ``fn(task)`` for each task; :meth:`map_unordered` yields ``(index, result)``."""

    description = "in this process"
    workers = 1

    def map_unordered(self, fn: Callable[[Any], Any], tasks: Sequence[Any]
                      ) -> Iterator[tuple[int, Any]]:
        """Run ``fn`` on every task; yield ``(index, result)`` pairs as they finish (here: in
        order, in this process)."""
        for k, task in enumerate(tasks):
            yield k, fn(task)

    def close(self) -> None:
        """Release the executor's workers (nothing to release in this process)."""
        pass

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class ProcessExecutor(Executor):
    """A local process pool of ``workers`` processes (started on first use)."""

    def __init__(self, workers: int) -> None:
        self.workers = workers
        self.description = f"a local process pool of {workers} workers"
        self._pool: ProcessPoolExecutor | None = None

    def map_unordered(self, fn, tasks):
        if self._pool is None:
            # forkserver: workers fork from a fresh server process, never from this one,
            # which may hold an EGL context (a forked copy of one crashes the worker)
            self._pool = ProcessPoolExecutor(
                max_workers=self.workers, initializer=_pool_worker_init,
                mp_context=multiprocessing.get_context("forkserver"))
        pending = {self._pool.submit(fn, task): k for k, task in enumerate(tasks)}
        try:
            while pending:
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for fut in sorted(done, key=pending.__getitem__):
                    k = pending.pop(fut)
                    yield k, fut.result()
        finally:
            for fut in pending:
                fut.cancel()

    def close(self) -> None:
        """Shut the process pool down, cancelling tasks not yet started."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None


class DaskExecutor(Executor):
    """dask.distributed: ``address`` "local" starts a LocalCluster on loopback with
    ``workers`` single-threaded worker processes; ``tcp://host:port`` joins a cluster."""

    def __init__(self, address: str, workers: int) -> None:
        try:
            from dask.distributed import Client, LocalCluster
        except ImportError:
            raise InputError("--dask: dask.distributed is not installed; install the extra: "
                             "pip install 'rasc[dask]'") from None
        self._cluster = None
        worker_environment()          # inherited by the LocalCluster's worker processes
        if address == "local":
            self._cluster = LocalCluster(n_workers=workers, threads_per_worker=1,
                                         processes=True, dashboard_address=None,
                                         host="127.0.0.1")
            self.client = Client(self._cluster)
            self.workers = workers
            self.description = f"a dask LocalCluster of {workers} workers"
        else:
            if not address.startswith(("tcp://", "tls://")):
                raise InputError(f"--dask: expected 'local' or a scheduler address such as "
                                 f"tcp://host:8786, got {address!r}")
            try:
                self.client = Client(address, timeout="10s")
            except (OSError, TimeoutError) as exc:
                raise InputError(f"--dask {address}: cannot reach the scheduler: "
                                 f"{' '.join(str(exc).split())}") from None
            self.workers = max(1, len(self.client.scheduler_info().get("workers", {})))
            self.description = f"the dask cluster at {address} ({self.workers} workers)"
        self.client.run(worker_environment)

    def map_unordered(self, fn, tasks):
        from dask.distributed import as_completed

        futures = [self.client.submit(fn, task, pure=False) for task in tasks]
        index = {f.key: k for k, f in enumerate(futures)}
        try:
            for fut in as_completed(futures):
                yield index[fut.key], fut.result()
        finally:
            self.client.cancel([f for f in futures if not f.done()])

    def close(self) -> None:
        """Close the dask client (and the local cluster, if this executor started one)."""
        self.client.close()
        if self._cluster is not None:
            self._cluster.close()


def make_executor(workers: int = 1, dask: str | None = None) -> Executor:
    """The executor for ``--workers N`` / ``--dask ADDRESS``."""
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise InputError(f"--workers: expected an integer >= 1, got {workers!r}")
    if dask is not None:
        return DaskExecutor(dask, workers)
    return Executor() if workers == 1 else ProcessExecutor(workers)
