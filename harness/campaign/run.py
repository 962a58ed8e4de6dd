"""A campaign: every log of a database through every chosen estimator with every settings file, on
a pool of workers (a Dask cluster by default), each run's row cached by (log content, generated C,
settings) so that only new logs, new code or new settings are computed."""

from __future__ import annotations

import glob
import hashlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from vsegen.harness.campaign import cache
from vsegen.harness.campaign.job import log_job
from vsegen.harness.logs.sources import LOG_SUFFIXES
from vsegen.harness.logs.table import LogError
from vsegen.model.params import VehicleConfig


@dataclass(frozen=True)
class Settings:
    """A vehicle/settings file of the campaign, under a short label (its file stem)."""

    label: str
    config: VehicleConfig
    digest: str
    """SHA-256 of the file's content."""


@dataclass
class CampaignResult:
    """The rows (one per log x estimator x settings, in log order), the logs that failed with their
    one-line reasons, how many runs were computed and how many read from the cache, and the
    workers that computed them."""

    rows: list[dict] = field(default_factory=list)
    failed: list[tuple[str, str]] = field(default_factory=list)
    computed: int = 0
    cached: int = 0
    workers: set[str] = field(default_factory=set)


def find_logs(patterns: Sequence[str]) -> list[Path]:
    """The logs named by ``patterns``: files, folders (searched recursively for LOG_SUFFIXES) and
    glob patterns, each log once, sorted; LogError when a pattern names nothing."""
    found: dict[Path, None] = {}
    for pattern in patterns:
        path = Path(pattern)
        if path.is_dir():
            matches = [p for p in path.rglob("*") if p.is_file() and p.name.lower().endswith(LOG_SUFFIXES)]
        elif path.is_file():
            matches = [path]
        else:
            matches = [Path(p) for p in glob.glob(pattern, recursive=True) if Path(p).is_file()]
        if not matches:
            raise LogError(f"{pattern}: no log: expected a log file, a folder of logs ({', '.join(LOG_SUFFIXES)}) "
                           f"or a glob pattern that matches some")
        found.update(dict.fromkeys(sorted(p.resolve() for p in matches)))
    return sorted(found)


def run_campaign(logs: Sequence[Path], estimators: Sequence[str], settings: Sequence[Settings],
                 channels: Path | None, dbc: Path | None, pool,
                 on_log: Callable[[str, bool], None] | None = None) -> CampaignResult:
    """Every log x estimator x settings: cached rows read, the rest computed on ``pool`` (a
    :class:`~vsegen.harness.jobs.pool.Pool`), one job per log; ``on_log(log, ok)`` as each log is
    done (cached logs first)."""
    from vsegen.codegen.generate import render

    code = {(s.label, name): _digest_of(render(s.config, name)) for s in settings for name in estimators}
    inputs = "\0".join(cache.file_digest(p) if p else "" for p in (channels, dbc))
    result = CampaignResult()
    rows: dict[tuple[str, str, str], dict] = {}
    jobs, keys = [], []
    for log in logs:
        digest = cache.file_digest(log)
        pending = []
        for s in settings:
            for name in estimators:
                key = cache.run_key(digest, name, s.digest, code[(s.label, name)], inputs)
                row = cache.load(key)
                if row is None:
                    pending.append((name, s.label, s.config, key))
                else:
                    rows[(str(log), s.label, name)] = {**row, "log": str(log), "settings": s.label}
                    result.cached += 1
        if pending:
            jobs.append((str(log), str(channels) if channels else None, str(dbc) if dbc else None,
                         [(name, label, config) for name, label, config, _ in pending]))
            keys.append([key for *_, key in pending])
        elif on_log:
            on_log(str(log), True)

    def done(index: int, outcome: dict) -> None:
        log = jobs[index][0]
        result.workers.add(outcome["worker"])
        if "error" in outcome:
            result.failed.append((log, outcome["error"]))
        else:
            for key, row in zip(keys[index], outcome["rows"]):
                row = {"log": log, **row}
                cache.store(key, row)
                rows[(log, row["settings"], row["estimator"])] = row
                result.computed += 1
        if on_log:
            on_log(log, "error" not in outcome)

    pool.map(log_job, jobs, on_done=done)
    result.rows = [rows[(str(log), s.label, name)] for log in logs for s in settings for name in estimators
                   if (str(log), s.label, name) in rows]
    result.failed.sort()
    return result


def _digest_of(files: dict[str, str]) -> str:
    digest = hashlib.sha256()
    for name in sorted(files):
        digest.update(name.encode() + b"\0" + files[name].encode() + b"\0")
    return digest.hexdigest()
