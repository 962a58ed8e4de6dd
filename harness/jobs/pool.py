"""One pool interface over worker processes and Dask clusters.

``pool.map(function, jobs)`` calls ``function(*job)`` for every job and returns the results in job
order, whichever finishes first; ``on_done(index, result)`` is called in this process as each job
finishes. ``function`` must be a module-level function and the jobs picklable. Jobs are pure
functions of their arguments, so results are identical, bit for bit, whichever pool ran them (on
workers with the same compiler and libraries).

* :class:`ProcessPool`: worker processes on this machine (``VSEGEN_WORKERS``, default the number of
  cores), started at the first :meth:`Pool.map` that needs them; with one worker, or fewer jobs
  than it takes to pay for starting them, jobs run in this process.
* :class:`DaskPool`: a Dask cluster. ``scheduler`` (else ``$VSEGEN_SCHEDULER``, else "local") is
  "local" (a ``distributed.LocalCluster``, one single-threaded worker process per core), "serial"
  (every job in this process) or the address of a running scheduler such as ``tcp://10.0.0.5:8786``
  (its workers need only vsegen installed; they compile the C they run themselves).
"""

from __future__ import annotations

import logging
import multiprocessing
import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any

MIN_PARALLEL_JOBS = 4
"""Fewer jobs than this run in-process on a ProcessPool: starting the workers costs about a second."""
SCHEDULER_VARIABLE = "VSEGEN_SCHEDULER"
CONNECT_TIMEOUT = "10s"
ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
"""Workers run their linear algebra single-threaded: the matrices are tiny, and a BLAS thread
that spins while another worker holds the core made scipy's expm 9x slower (measured)."""
PRELOAD = ("vsegen.model.estimators",)
"""Modules a process pool's fork server imports once, so CasADi and NumPy load once."""


class WorkerCountError(ValueError):
    """``VSEGEN_WORKERS`` is not a positive integer; the message is one line."""


class ClusterError(RuntimeError):
    """The scheduler cannot be reached; the message is one line."""


def worker_count() -> int:
    """``VSEGEN_WORKERS`` if set (a positive integer), else the number of cores."""
    text = os.environ.get("VSEGEN_WORKERS", "")
    if not text:
        return os.cpu_count() or 1
    if not text.isdigit() or int(text) < 1:
        raise WorkerCountError(f"VSEGEN_WORKERS = {text!r}: expected a positive integer "
                               f"(worker processes)")
    return int(text)


class Pool:
    """The shared part of every pool: job order, ``on_done`` and the in-process path. A pool is a
    context manager; its workers live for the ``with`` block."""

    def __enter__(self) -> Pool:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Stop the workers (nothing to do for a pool that has none)."""

    def map(self, function: Callable[..., Any], jobs: Sequence[tuple],
            on_done: Callable[[int, Any], None] | None = None) -> list[Any]:
        """``[function(*job) for job in jobs]``, in job order."""
        results: list[Any] = [None] * len(jobs)
        finished = (((i, function(*job)) for i, job in enumerate(jobs)) if self.in_process(len(jobs))
                    else self.completed(function, jobs))
        for index, result in finished:
            results[index] = result
            if on_done:
                on_done(index, result)
        return results

    def in_process(self, jobs: int) -> bool:
        """Whether ``jobs`` jobs run in this process, one after the other."""
        return True

    def completed(self, function: Callable[..., Any], jobs: Sequence[tuple]) -> Iterator[tuple[int, Any]]:
        """(index, result) of every job, as the workers finish them."""
        raise NotImplementedError


class ProcessPool(Pool):
    """Worker processes on this machine, forked from a server that has imported ``preload``."""

    def __init__(self, count: int | None = None, preload: Sequence[str] = PRELOAD) -> None:
        self.count = worker_count() if count is None else count
        self.preload = list(preload)
        self._executor: ProcessPoolExecutor | None = None

    def close(self) -> None:
        if self._executor is not None:
            self._executor.shutdown(cancel_futures=True)
            self._executor = None

    def in_process(self, jobs: int) -> bool:
        return self.count <= 1 or (self._executor is None and jobs < MIN_PARALLEL_JOBS)

    def completed(self, function, jobs):
        futures = {self._started().submit(function, *job): index for index, job in enumerate(jobs)}
        for future in as_completed(futures):
            yield futures[future], future.result()

    def _started(self) -> ProcessPoolExecutor:
        if self._executor is None:
            for variable, value in ONE_THREAD.items():      # read by the fork server when it starts
                os.environ.setdefault(variable, value)
            context = multiprocessing.get_context("forkserver")
            context.set_forkserver_preload(self.preload)
            self._executor = ProcessPoolExecutor(max_workers=self.count, mp_context=context)
        return self._executor


class DaskPool(Pool):
    """A Dask client for the ``with`` block (none for "serial"); see the module docstring."""

    def __init__(self, scheduler: str | None = None) -> None:
        self.scheduler = scheduler or os.environ.get(SCHEDULER_VARIABLE) or "local"
        self._client = None
        self._local = None

    def __enter__(self) -> DaskPool:
        if self.scheduler == "serial":
            return self
        from distributed import Client, LocalCluster

        try:
            if self.scheduler == "local":
                self._local = LocalCluster(n_workers=worker_count(), threads_per_worker=1, processes=True,
                                           dashboard_address=None, env=ONE_THREAD, silence_logs=logging.ERROR)
                self._client = Client(self._local)
            else:
                self._client = Client(self.scheduler, timeout=CONNECT_TIMEOUT)
        except OSError as exc:
            raise ClusterError(f"scheduler {self.scheduler}: cannot connect ({exc}): expected the address "
                               f"of a running dask scheduler, e.g. tcp://host:8786, or 'local'/'serial'") from None
        return self

    def close(self) -> None:
        if self._client is not None:
            self._client.close()
        if self._local is not None:
            self._local.close()
        self._client = self._local = None

    @property
    def workers(self) -> int:
        """Number of workers (1 for serial)."""
        return 1 if self._client is None else max(1, len(self._client.scheduler_info()["workers"]))

    def in_process(self, jobs: int) -> bool:
        return self._client is None

    def on_workers(self, function: Callable[[], Any]) -> list[Any]:
        """``function()`` on every worker (in this process for "serial"), e.g. to read their peak memory."""
        if self._client is None:
            return [function()]
        return list(self._client.run(function).values())

    def completed(self, function, jobs):
        from distributed import as_completed as dask_completed

        futures = [self._client.submit(function, *job, pure=False) for job in jobs]
        index_of = {future.key: i for i, future in enumerate(futures)}
        for future in dask_completed(futures):
            yield index_of[future.key], future.result()
