"""The jobs a campaign's workers run: one log, read once in chunks, through every (estimator,
settings) it still needs; one row each (:mod:`~vsegen.harness.campaign.row`); a log that cannot
be read, or lacks what an estimator needs, comes back as its one-line reason instead. And one
simulated scenario scored for a Monte-Carlo sweep (``python -m bench.accuracy``)."""

from __future__ import annotations

import os
import socket
from pathlib import Path

from vsegen.harness.campaign.row import RowSums
from vsegen.harness.host.run_log import EstimatorStream, run_estimator
from vsegen.harness.logs.table import LogError
from vsegen.harness.physics.checked_log import open_checked_log
from vsegen.harness.score.metrics import Score, score
from vsegen.model.params import ParameterError, VehicleConfig


def log_job(log: str, channels: str | None, dbc: str | None,
            runs: list[tuple[str, str, VehicleConfig]]) -> dict:
    """``{"rows": [row per run], "worker": host:pid}`` for the log at ``log`` (through the channel
    map ``channels`` and, for raw CAN, the DBC ``dbc``) and each run (estimator, settings label,
    vehicle configuration); ``{"error": one line, ...}`` when the log cannot be used."""
    worker = f"{socket.gethostname()}:{os.getpid()}"
    try:
        first = runs[0][2]
        source, _ = open_checked_log(Path(log), Path(channels) if channels else None, first.sample_time,
                                     dbc=Path(dbc) if dbc else None, config=first)
        with source:
            streams = [EstimatorStream(config, name, source.sample_time) for name, _, config in runs]
            sums = [RowSums(source.sample_time) for _ in runs]
            for chunk in source.chunks():
                for stream, row in zip(streams, sums):
                    row.add(chunk, stream(chunk))
    except (LogError, ParameterError) as exc:
        return {"error": str(exc), "worker": worker}
    rows = [{"estimator": name, "settings": label, "sample_time_s": source.sample_time, **row.row()}
            for (name, label, _), row in zip(runs, sums)]
    return {"rows": rows, "worker": worker}


def scenario_job(config, case, seed: int, names: tuple[str, ...]) -> tuple[dict, dict[str, list[Score]]]:
    """(the run's notes, per estimator its scores against the truth) of scenario ``case``
    (``harness.sim.scenarios.Case``) with sensor-noise ``seed``, each estimator's generated C run over
    the log: one job of a Monte-Carlo sweep on the cluster (workers need only vsegen installed)."""
    log = case.simulate(config, 1.0 / config.sample_time, seed)
    return dict(log.notes), {name: score(log, run_estimator(config, name, log)) for name in names}
