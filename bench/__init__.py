"""Benchmarks and accuracy reports (run as commands, never as pass/fail tests)."""

from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
"""The checkout the benchmarks read vehicles from and write docs/ into."""
VEHICLES = REPO / "vehicles"
DEFAULT_VEHICLE = VEHICLES / "c_class.toml"
BENCHMARKS = REPO / "docs" / "benchmarks.md"
"""The benchmark report; each section-writing command replaces its own section."""
