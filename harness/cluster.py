"""Runs spread over a Dask cluster: the machine's cores by default, or an existing cluster.

``Cluster(scheduler).map(function, jobs)`` calls ``function(*job)`` for every job and returns the
results in job order. ``scheduler`` (else ``$VSEGEN_SCHEDULER``, else "local") is

* ``"local"``: a ``distributed.LocalCluster`` with one single-threaded worker process per core
  (``VSEGEN_WORKERS`` overrides the count), started for the ``with`` block;
* ``"serial"``: every job in this process, one after the other;
* an address such as ``tcp://10.0.0.5:8786``: an existing cluster, whose workers need only vsegen
  installed (they compile the generated C they run themselves).

Jobs are pure functions of their arguments, so results are identical, bit for bit, whichever
scheduler ran them (on workers with the same compiler and libraries).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Sequence
from typing import Any

from vsegen.harness.parallel import worker_count

SCHEDULER_VARIABLE = "VSEGEN_SCHEDULER"
_ONE_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
CONNECT_TIMEOUT = "10s"


class ClusterError(RuntimeError):
    """The scheduler cannot be reached; the message is one line."""


class Cluster:
    """A Dask client for the ``with`` block (none for "serial")."""

    def __init__(self, scheduler: str | None = None) -> None:
        self.scheduler = scheduler or os.environ.get(SCHEDULER_VARIABLE) or "local"
        self._client = None
        self._local = None

    def __enter__(self) -> Cluster:
        if self.scheduler == "serial":
            return self
        from distributed import Client, LocalCluster

        try:
            if self.scheduler == "local":
                self._local = LocalCluster(n_workers=worker_count(), threads_per_worker=1, processes=True,
                                           dashboard_address=None, env=_ONE_THREAD, silence_logs=logging.ERROR)
                self._client = Client(self._local)
            else:
                self._client = Client(self.scheduler, timeout=CONNECT_TIMEOUT)
        except OSError as exc:
            raise ClusterError(f"scheduler {self.scheduler}: cannot connect ({exc}): expected the address "
                               f"of a running dask scheduler, e.g. tcp://host:8786, or 'local'/'serial'") from None
        return self

    def __exit__(self, *exc) -> None:
        if self._client is not None:
            self._client.close()
        if self._local is not None:
            self._local.close()
        self._client = self._local = None

    @property
    def workers(self) -> int:
        """Number of workers (1 for serial)."""
        return 1 if self._client is None else max(1, len(self._client.scheduler_info()["workers"]))

    def map(self, function: Callable[..., Any], jobs: Sequence[tuple],
            on_done: Callable[[int, Any], None] | None = None) -> list[Any]:
        """``[function(*job) for job in jobs]``; ``on_done(index, result)`` is called in this
        process as each job finishes."""
        results: list[Any] = [None] * len(jobs)
        if self._client is None:
            for index, job in enumerate(jobs):
                results[index] = function(*job)
                if on_done:
                    on_done(index, results[index])
            return results
        from distributed import as_completed

        futures = [self._client.submit(function, *job, pure=False) for job in jobs]
        index_of = {future.key: i for i, future in enumerate(futures)}
        for future in as_completed(futures):
            index = index_of[future.key]
            results[index] = future.result()
            if on_done:
                on_done(index, results[index])
        return results
