"""The campaign cache: one JSON row per (log content, generated C, settings), under the build cache
(``cache_dir()/campaign``), so a campaign that meets a log it has run before with the same code
and settings reads the row instead of running it. A log's content digest is kept by (path, size,
modification time), so an unchanged database is not re-hashed either."""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

from vsegen.harness.project.files import write_text_atomic
from vsegen.harness.project.paths import cache_dir

FORMAT = 1
"""Bumped whenever a row's columns or their meaning change: older rows are then not reused."""
HASH_BLOCK = 1 << 20


def folder() -> Path:
    return cache_dir() / "campaign"


def file_digest(path: Path) -> str:
    """SHA-256 (hex) of a file's content, remembered by (path, size, mtime) in the cache."""
    path = Path(path).resolve()
    stat = path.stat()
    index_path = folder() / "digests.json"
    try:
        index = json.loads(index_path.read_text())
    except (OSError, ValueError):
        index = {}
    key = f"{path}|{stat.st_size}|{stat.st_mtime_ns}"
    if key not in index:
        digest = hashlib.sha256()
        with open(path, "rb") as handle:
            while block := handle.read(HASH_BLOCK):
                digest.update(block)
        index[key] = digest.hexdigest()
        write_text_atomic(index_path, json.dumps(index, sort_keys=True))
    return index[key]


def run_key(*parts: str) -> str:
    """The cache key of one run: a digest of its parts (log digest, estimator, settings digest,
    generated-C digest, channel map and DBC digests) and FORMAT."""
    return hashlib.sha256("\0".join((str(FORMAT), *parts)).encode()).hexdigest()


def load(key: str) -> dict | None:
    """The cached row of ``key``, or None."""
    try:
        row = json.loads((folder() / key[:2] / f"{key}.json").read_text())
    except (OSError, ValueError):
        return None
    return {name: math.nan if value is None else value for name, value in row.items()}


def store(key: str, row: dict) -> None:
    """Keep ``row`` (NaN stored as null) for ``key``."""
    plain = {name: None if isinstance(value, float) and math.isnan(value) else value for name, value in row.items()}
    write_text_atomic(folder() / key[:2] / f"{key}.json", json.dumps(plain, sort_keys=True))
