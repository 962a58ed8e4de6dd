"""Independent runs spread over the machine's cores.

``Workers().map(function, jobs)`` calls ``function(*job)`` for every job and returns the results in
job order, whichever finishes first. Jobs go to a pool of worker processes (``VSEGEN_WORKERS``, default
the number of cores); with one worker or fewer jobs than it takes to pay for starting the pool they
run in this process. Workers are forked from a server that has imported ``harness.verify`` (so CasADi
and NumPy load once); ``function`` must be a module-level function and the jobs picklable.
A worker's results equal the in-process results bit for bit: the same code on the same inputs.
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any

MIN_PARALLEL_JOBS = 4
"""Fewer jobs than this run in-process: starting the workers costs about a second."""
_PRELOAD = ["vsegen.harness.verify"]
_ONE_THREAD = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
"""Workers run their linear algebra single-threaded: the matrices are tiny, and a BLAS thread
that spins while another worker holds the core made scipy's expm 9x slower (measured)."""


class WorkerCountError(ValueError):
    """``VSEGEN_WORKERS`` is not a positive integer; the message is one line."""


def worker_count() -> int:
    """``VSEGEN_WORKERS`` if set (a positive integer), else the number of cores."""
    text = os.environ.get("VSEGEN_WORKERS", "")
    if not text:
        return os.cpu_count() or 1
    if not text.isdigit() or int(text) < 1:
        raise WorkerCountError(f"VSEGEN_WORKERS = {text!r}: expected a positive integer "
                               f"(worker processes)")
    return int(text)


class Workers:
    """A pool of worker processes, started at the first :meth:`map` that needs it and stopped when
    the ``with`` block ends; ``count`` defaults to :func:`worker_count`."""

    def __init__(self, count: int | None = None) -> None:
        self.count = worker_count() if count is None else count
        self._pool: ProcessPoolExecutor | None = None

    def __enter__(self) -> Workers:
        return self

    def __exit__(self, *exc) -> None:
        if self._pool is not None:
            self._pool.shutdown(cancel_futures=True)
            self._pool = None

    def map(self, function: Callable[..., Any], jobs: Sequence[tuple],
            on_done: Callable[[int, Any], None] | None = None) -> list[Any]:
        """``[function(*job) for job in jobs]``; ``on_done(index, result)`` is called in this
        process as each job finishes."""
        results: list[Any] = [None] * len(jobs)
        if self.count <= 1 or (self._pool is None and len(jobs) < MIN_PARALLEL_JOBS):
            for index, job in enumerate(jobs):
                results[index] = function(*job)
                if on_done:
                    on_done(index, results[index])
            return results
        futures = {self._executor().submit(function, *job): index for index, job in enumerate(jobs)}
        for future in as_completed(futures):
            index = futures[future]
            results[index] = future.result()
            if on_done:
                on_done(index, results[index])
        return results

    def _executor(self) -> ProcessPoolExecutor:
        if self._pool is None:
            for variable in _ONE_THREAD:       # read by the forkserver when it starts
                os.environ.setdefault(variable, "1")
            context = multiprocessing.get_context("forkserver")
            context.set_forkserver_preload(_PRELOAD)
            self._pool = ProcessPoolExecutor(max_workers=self.count, mp_context=context)
        return self._pool
