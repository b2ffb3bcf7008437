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

import contextlib
import logging
import multiprocessing
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import Any

from rasc.errors import InputError, RascError

#: single-threaded numerical libraries in every worker: N workers use N cores, and a
#: result never depends on a library's thread count
THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


class WorkerCrashed(RascError):
    """A worker process ended while it ran a task (a crash in native code, a kill, an
    exit no Python code could stop): one line, not a BrokenProcessPool traceback."""


#: how long stopping a pool's workers may take before they are killed, s
STOP_GRACE_S = 2.0

#: how a message names each option of :func:`make_executor` (and of
#: :func:`rasc.study.run_study`) when the caller gives no ``names`` of its own: the
#: library's parameter; a command passes its flags (``{"workers": "--workers", ...}``)
OPTION_NAMES = {"out": "out", "resume": "resume=True", "workers": "workers", "dask": "dask"}


def option_names(names: dict[str, str] | None = None) -> dict[str, str]:
    """:data:`OPTION_NAMES` with the caller's ``names`` over them."""
    return {**OPTION_NAMES, **(names or {})}


def _order(key: Any) -> tuple:
    """Futures finished together are handed over in the order of their keys (task
    indices), whatever the keys' type."""
    return (0, key) if isinstance(key, int) else (1, str(key))


def worker_environment() -> None:
    """What every worker process sets before its first task (idempotent)."""
    os.environ.setdefault("MUJOCO_GL", "egl")
    for var in THREAD_VARS:
        os.environ.setdefault(var, "1")


def no_process_locks() -> None:
    """tqdm's lock in a worker: a thread lock, not its default multiprocessing lock (a
    named semaphore that a worker killed while it renders would leave to the resource
    tracker, which then reports it as leaked)."""
    import threading

    from tqdm import tqdm
    tqdm.set_lock(threading.RLock())


def _pool_worker_init() -> None:
    """A process-pool worker: :func:`worker_environment`, Ctrl-C left to the parent (it
    reaches the whole process group; the parent stops the pool and says what it kept, a
    worker must not print a traceback of its own), SIGTERM (the parent stopping it) the
    end, at once."""
    import signal

    from rasc.interrupt import end_by_sigterm
    worker_environment()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # stopped by the parent (ProcessExecutor.abort): at once (a render's files are in the
    # study's scratch folder, which the parent removes)
    signal.signal(signal.SIGTERM, end_by_sigterm)
    no_process_locks()


class Executor:
    """Runs ``fn(task)`` for each task: :meth:`map_unordered` yields ``(index, result)``
    for a list of tasks; :meth:`submit` and :meth:`completed` are the same one task at a
    time, for a caller that submits while it computes (reproduce.py starts the
    experiments that need no default dataset while it calibrates that dataset)."""

    description = "in this process"
    workers = 1

    def map_unordered(self, fn: Callable[[Any], Any], tasks: Sequence[Any]
                      ) -> Iterator[tuple[int, Any]]:
        """Run ``fn`` on every task; yield ``(index, result)`` pairs as they finish (here: in
        order, in this process)."""
        for k, task in enumerate(tasks):
            yield k, fn(task)

    def submit(self, fn: Callable[[Any], Any], task: Any) -> Future:
        """Start ``fn(task)``; its future (here: run now, in this process; an exception
        it raises is the future's)."""
        fut: Future = Future()
        try:
            fut.set_result(fn(task))
        except Exception as exc:  # noqa: BLE001 -- handed over by Future.result()
            fut.set_exception(exc)
        return fut

    def completed(self, futures: dict[Future, Any]) -> Iterator[tuple[Any, Any]]:
        """Wait for ``futures`` (a dict future → the caller's key); yield ``(key, result)``
        as each finishes, taking them out of the dict. A task's exception is raised here;
        a worker process that ended while it ran one raises :class:`WorkerCrashed`. Not
        yet started futures left in the dict on an exit from the loop are cancelled."""
        from concurrent.futures.process import BrokenProcessPool

        try:
            while futures:
                done, _ = wait(futures, return_when=FIRST_COMPLETED)
                for fut in sorted(done, key=lambda f: _order(futures[f])):
                    key = futures.pop(fut)
                    try:
                        result = fut.result()
                    except BrokenProcessPool:
                        self.abort()
                        which = f"task {key}" if isinstance(key, int) else key
                        raise WorkerCrashed(f"a worker process ended while it ran "
                                            f"{getattr(fut, 'rasc_what', 'a task')} "
                                            f"({which})") from None
                    yield key, result
        finally:
            for fut in futures:
                fut.cancel()

    def close(self) -> None:
        """Release the executor's workers (nothing to release in this process)."""
        pass

    def abort(self) -> None:
        """Stop at once (after an interrupt): running tasks are abandoned, every worker
        process is ended within :data:`STOP_GRACE_S`."""
        self.close()

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, kind, value, tb) -> None:
        if kind is not None and issubclass(kind, KeyboardInterrupt):
            self.abort()              # interrupted: stop the workers, do not wait
        self.close()


class ProcessExecutor(Executor):
    """A local process pool of ``workers`` processes (started on first use)."""

    def __init__(self, workers: int) -> None:
        self.workers = workers
        self.description = f"a local process pool of {workers} workers"
        self._pool: ProcessPoolExecutor | None = None

    def submit(self, fn, task):
        """Start ``fn(task)`` in a worker process (the pool starts on first use: its
        resource tracker, forkserver and first worker within
        :func:`rasc.interrupt.starting_helpers`, so a Ctrl-C meanwhile reaches only this
        process, which then stops them)."""
        if self._pool is not None:
            fut = self._pool.submit(fn, task)
        else:
            from rasc.interrupt import starting_helpers
            try:
                with starting_helpers():     # (the resource tracker first, quietly)
                    # forkserver: workers fork from a fresh server process, never from
                    # this one, which may hold an EGL context (a forked copy of one
                    # crashes the worker)
                    self._pool = ProcessPoolExecutor(
                        max_workers=self.workers, initializer=_pool_worker_init,
                        mp_context=multiprocessing.get_context("forkserver"))
                    fut = self._pool.submit(fn, task)
            except KeyboardInterrupt:
                self.abort()
                raise
        fut.rasc_what = getattr(fn, "__name__", "a task")
        return fut

    def map_unordered(self, fn, tasks):
        pending = {self.submit(fn, task): k for k, task in enumerate(tasks)}
        yield from self.completed(pending)

    def close(self) -> None:
        """Shut the process pool down, cancelling tasks not yet started."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def abort(self) -> None:
        """End every worker (SIGTERM, then SIGKILL after :data:`STOP_GRACE_S`; a worker
        stuck in a task that never returns is not waited for), then shut the pool."""
        pool, self._pool = self._pool, None
        if pool is None:
            return
        import time
        procs = list((getattr(pool, "_processes", None) or {}).values())
        _drop_cancelled(pool)               # (the pool forgets its processes here)
        for p in procs:
            with contextlib.suppress(Exception):
                p.terminate()
        deadline = time.monotonic() + STOP_GRACE_S
        for p in procs:
            with contextlib.suppress(Exception):
                p.join(max(0.0, deadline - time.monotonic()))
                if p.is_alive():
                    p.kill()
                    p.join(1.0)
        with contextlib.suppress(Exception):
            pool.shutdown(wait=True, cancel_futures=True)


def _drop_cancelled(pool: ProcessPoolExecutor, timeout_s: float = 1.0) -> None:
    """Let the pool's manager thread drop the futures cancelled before they reached a
    worker, before the workers are ended: Python 3.11's manager then sets an exception on
    every future it still holds, raises InvalidStateError on a cancelled one and dies
    with a traceback on stderr, before it has cleaned up (fixed in 3.12). Shutting down
    with ``cancel_futures`` makes it drop them; it says it has by clearing the flag."""
    with contextlib.suppress(Exception):
        pool.shutdown(wait=False, cancel_futures=True)
        import time
        manager = getattr(pool, "_executor_manager_thread", None)
        deadline = time.monotonic() + timeout_s
        while (manager is not None and manager.is_alive()
               and getattr(pool, "_cancel_pending_futures", False)
               and time.monotonic() < deadline):
            time.sleep(0.005)


def _quiet_after_an_interrupt(record: logging.LogRecord) -> bool:
    """A logging filter: nothing once SIGINT or SIGTERM has arrived."""
    from rasc.interrupt import received
    return not received()


class DaskExecutor(Executor):
    """dask.distributed: ``address`` "local" starts a LocalCluster on loopback with
    ``workers`` single-threaded worker processes; ``tcp://host:port`` joins a cluster."""

    def __init__(self, address: str, workers: int, names: dict[str, str] | None = None
                 ) -> None:
        name = option_names(names)["dask"]
        try:
            import dask.distributed  # noqa: F401
        except ImportError:
            raise InputError(f"{name}: dask.distributed is not installed; install the "
                             "extra: pip install 'rasc[dask]'") from None
        self._cluster = None
        self._scratch = None
        self.client = None
        worker_environment()          # inherited by the LocalCluster's worker processes
        try:
            self._start(address, workers, name)
        except BaseException:
            self.close()          # what started (a cluster cut short by an interrupt too)
            raise

    def _start(self, address: str, workers: int, name: str) -> None:
        from dask.distributed import Client

        from rasc.interrupt import starting_helpers
        if address == "local":
            # the workers' scratch space in a temporary folder (not dask-scratch-space/
            # in the working folder), removed on close; Ctrl-C is this process's to
            # handle (a terminal sends it to the whole process group): the workers start
            # without it (starting_helpers) and are stopped by close(); one that arrives
            # while they start is raised once the cluster is up, and close() stops it
            import dask
            self._scratch = tempfile.mkdtemp(prefix="rasc-dask-")
            # every temporary file of the cluster there (not dask-scratch-space/ in the
            # temporary folder); the workers log only errors (a task cancelled by an
            # interrupt is no warning of theirs: the study says what it kept)
            dask.config.set({"temporary-directory": self._scratch})
            os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "error")
            with starting_helpers():
                self._start_local(workers)
        else:
            if not address.startswith(("tcp://", "tls://")):
                raise InputError(f"{name}: expected 'local' or a scheduler address such as "
                                 f"tcp://host:8786, got {address!r}")
            try:
                self.client = Client(address, timeout="10s")
            except (OSError, TimeoutError) as exc:
                raise InputError(f"{name} {address}: cannot reach the scheduler: "
                                 f"{' '.join(str(exc).split())}") from None
            self.workers = max(1, len(self.client.scheduler_info().get("workers", {})))
            self.description = f"the dask cluster at {address} ({self.workers} workers)"
            self.client.run(worker_environment)
            self.client.run(no_process_locks)

    def _start_local(self, workers: int) -> None:
        """The LocalCluster, its client and the workers' settings."""
        from dask.distributed import Client, LocalCluster

        self._cluster = LocalCluster(n_workers=workers, threads_per_worker=1,
                                     processes=True,
                                     # a free loopback port: the scheduler's HTTP server
                                     # starts even without a dashboard, and 8787 may be
                                     # taken
                                     dashboard_address="127.0.0.1:0", host="127.0.0.1",
                                     local_directory=self._scratch,
                                     # distributed's own warnings (a worker ended by an
                                     # interrupt: "exit status was already read") are not
                                     # the user's news
                                     silence_logs=logging.ERROR)
        # after an interrupt, the scheduler's errors about the workers it loses (a
        # SIGTERM to the whole process group ends them) are not the user's news
        for handler in logging.getLogger("distributed").handlers:
            handler.addFilter(_quiet_after_an_interrupt)
        self.client = Client(self._cluster)
        self.workers = workers
        self.description = f"a dask LocalCluster of {workers} workers"
        self.client.run(worker_environment)
        self.client.run(no_process_locks)

    def submit(self, fn, task):
        """Start ``fn(task)`` on the cluster; its dask future."""
        return self.client.submit(fn, task, pure=False)

    def completed(self, futures):
        """:meth:`Executor.completed` for dask futures."""
        from dask.distributed import as_completed

        by_key = {f.key: f for f in futures}
        try:
            for fut in as_completed(list(futures)):
                key = futures.pop(by_key[fut.key])
                yield key, fut.result()
        finally:
            self.client.cancel([f for f in futures if not f.done()])

    def map_unordered(self, fn, tasks):
        pending = {self.submit(fn, task): k for k, task in enumerate(tasks)}
        yield from self.completed(pending)

    def close(self) -> None:
        """Close the dask client (and the local cluster, if this executor started one)."""
        if self.client is not None:
            with contextlib.suppress(Exception):
                self.client.close(timeout=STOP_GRACE_S)
        if self._cluster is not None:
            with contextlib.suppress(Exception):
                self._cluster.close(timeout=STOP_GRACE_S)
            # the scheduler's work folder (in the scratch folder) is removed by its own
            # finalizer, which may run later: run it now (it runs once), then the rest
            with contextlib.suppress(Exception):
                self._cluster.scheduler._workdir.release()
            self._cluster = None
        if self._scratch is not None:
            shutil.rmtree(self._scratch, ignore_errors=True)
            self._scratch = None


def make_executor(workers: int = 1, dask: str | None = None,
                  names: dict[str, str] | None = None) -> Executor:
    """The executor for ``workers`` processes (1: this process) or the dask cluster
    ``dask``. ``names``: how messages name ``workers`` and ``dask`` (default: so,
    :data:`OPTION_NAMES`; the command line passes its flags)."""
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise InputError(f"{option_names(names)['workers']}: expected an integer >= 1, "
                         f"got {workers!r}")
    if dask is not None:
        return DaskExecutor(dask, workers, names)
    return Executor() if workers == 1 else ProcessExecutor(workers)
