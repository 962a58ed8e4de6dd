"""Where things live: the repository's folders and the build cache."""

from __future__ import annotations

import os
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
VEHICLES = REPO / "vehicles"
GENERATED = REPO / "generated"
DEFAULT_VEHICLE = VEHICLES / "c_class.toml"
REPORTS = REPO / "docs"


def cache_dir() -> Path:
    """Build cache: $VSEGEN_CACHE, else $XDG_CACHE_HOME/vsegen, else ~/.cache/vsegen."""
    if os.environ.get("VSEGEN_CACHE"):
        return Path(os.environ["VSEGEN_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "vsegen"
