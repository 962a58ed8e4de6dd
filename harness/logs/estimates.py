"""Estimates files, as ``vsegen run`` writes them and ``score`` and ``plot`` read them: CSV, or
ASAM MDF4 when the name ends in .mf4/.mdf, with ``t`` and the estimator's outputs in SI units. An
MDF4 file carries each channel's unit; on reading, a unit of the vocabulary of channel maps is
converted to SI, and a unit of the wrong kind or an unknown one is refused in one line."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from vsegen.harness.logs.channels import SI_KIND, UNITS
from vsegen.harness.logs.mdf import SUFFIXES, open_mdf, write_mdf
from vsegen.harness.logs.table import ESTIMATED, Log, LogError, read_log, write_log

KNOWN_UNITS = {"beta": "rad", "beta_ekf": "rad", "beta_int": "rad", "vx": "m/s", "vy": "m/s", "r": "rad/s",
               "ax": "m/s^2", "ay": "m/s^2", "yaw_moment": "N*m", "status": "-", "mode": "-"}
"""The SI unit of the outputs ``score`` and ``plot`` read (others are kept as they are)."""


def write_estimates(log: Log, path: Path, units: Mapping[str, str]) -> None:
    """Write ``log`` (``t`` and outputs) as MDF4 (by suffix, each channel with its unit from
    ``units``) or CSV, atomically."""
    if Path(path).suffix.lower() in SUFFIXES:
        write_mdf(log, path, units)
    else:
        write_log(log, path)


def read_estimates(path: Path) -> Log:
    """An estimates file: ``t``, at least one of ``beta``, ``vy``, ``r``, and other numeric columns,
    in SI units; LogError (one line) otherwise."""
    log = _read_mdf_estimates(path) if Path(path).suffix.lower() in SUFFIXES else \
        read_log(path, required=("t",), all_numeric=True)
    if not any(name in log for name in ESTIMATED):
        raise LogError(f"{path}:1: no estimated signal: expected a column {', '.join(ESTIMATED[:-1])} "
                       f"or {ESTIMATED[-1]} (found {', '.join(log.columns)})")
    return log


def _read_mdf_estimates(path: Path) -> Log:
    mdf = open_mdf(path)
    columns: dict[str, np.ndarray] = {}
    for name in mdf.channels_db:
        if name in ("t", "time") or name.startswith("$") or name in columns:
            continue
        signal = mdf.get(name, *mdf.channels_db[name][0])
        columns.setdefault("t", np.asarray(signal.timestamps, dtype=float))
        columns[name] = np.asarray(signal.samples, dtype=float) * _to_si(path, name, str(signal.unit or ""))
    if "t" not in columns:
        raise LogError(f"{path}: no channel: expected the estimates of `vsegen run --out EST.mf4`")
    return Log(columns, str(path))


def _to_si(path: Path, name: str, unit: str) -> float:
    """The factor from a channel's ``unit`` to its column's SI unit (1 where either is unknown)."""
    si = KNOWN_UNITS.get(name)
    if si is None or unit in ("", si):
        return 1.0
    if unit not in UNITS or UNITS[unit][0] != SI_KIND.get(si):
        raise LogError(f"{path}: channel '{name}' unit = {unit!r}: expected a unit of {SI_KIND.get(si, si)} "
                       f"(the column is in {si})")
    return UNITS[unit][1]

