"""Simulated logs kept on disk, so a scenario is simulated once per truth car, rate and seed.

A log is stored as ``<cache>/logs/<key>.npz`` (``harness.project.paths.cache_dir``). The key is the SHA-256
of everything a simulation depends on: the scenario and its options, the log rate, the noise seed,
the truth car (``VehicleConfig.truth_fingerprint``: the ``[vehicle]``, ``[plant]`` and
``[sensors]`` tables, never the estimator settings, which a simulation does not read) and the
source text of the simulating code (``harness/sim`` and
``harness/logs/table.py``), so editing the plant or a manoeuvre invalidates every entry. Entries are
written to a temporary name and renamed, so parallel workers never read a partial file; a damaged
entry is simulated again.
"""

from __future__ import annotations

import hashlib
import json
import zipfile
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from vsegen.harness.logs.table import Log
from vsegen.harness.project.files import atomic_path
from vsegen.harness.project.paths import cache_dir

_SIMULATING_CODE = ("sim", "logs/table.py")
"""What a simulated log depends on, relative to the harness package."""


@lru_cache(maxsize=1)
def code_digest() -> str:
    """SHA-256 of the source of the simulating code (sorted by path)."""
    root = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for part in _SIMULATING_CODE:
        paths = sorted((root / part).rglob("*.py")) if (root / part).is_dir() else [root / part]
        for path in paths:
            digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def log_key(config, scenario: str, options: dict[str, Any], rate_hz: float, seed: int) -> str:
    """The cache key of one simulated log (see the module docstring)."""
    what = {"scenario": scenario, "options": options, "rate_hz": rate_hz, "seed": seed,
            "car": config.truth_fingerprint(), "code": code_digest()}
    text = json.dumps(what, sort_keys=True, separators=(",", ":"), default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


def cached_log(key: str, simulate: Callable[[], Log]) -> Log:
    """The log stored under ``key``, or ``simulate()``'s, stored first."""
    path = cache_dir() / "logs" / f"{key}.npz"
    try:
        return _load(path)
    except (OSError, ValueError, KeyError, zipfile.BadZipFile):
        pass
    log = simulate()
    _store(path, log)
    return log


def _load(path: Path) -> Log:
    with np.load(path, allow_pickle=False) as data:
        names = json.loads(str(data["__names__"]))
        notes = json.loads(str(data["__notes__"]))
        return Log({name: data[f"column_{i}"] for i, name in enumerate(names)}, str(data["__source__"]),
                   notes)


def _store(path: Path, log: Log) -> None:
    arrays = {f"column_{i}": np.asarray(values) for i, values in enumerate(log.columns.values())}
    with atomic_path(path) as tmp, open(tmp, "wb") as handle:
        np.savez(handle, __names__=json.dumps(list(log.columns)),
                 __notes__=json.dumps(log.notes), __source__=log.source, **arrays)
