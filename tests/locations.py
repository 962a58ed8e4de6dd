"""The repository's folders, for the tests (the CLI finds its project from the current directory;
the tests always use this checkout's)."""

from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
VEHICLES = REPO / "vehicles"
GENERATED = REPO / "generated"
DEFAULT_VEHICLE = VEHICLES / "c_class.toml"
REVS = REPO / "data" / "real" / "revs_250lm"
"""The Revs lap: a real race car's log with an INS reference (its README gives source and licence)."""
