"""`vsegen init DIR`: a starter project for the user's own car.

It holds a commented vehicle file (a shipped car's values, to be replaced by the user's), a
channel-map example and a short README naming the next commands. Nothing is overwritten: a
folder that already has any of these files is refused in one line, before anything is written."""

from __future__ import annotations

import re
from pathlib import Path

from vsegen.harness.project.files import write_text_atomic
from vsegen.harness.project.paths import shipped_vehicle, shipped_vehicle_names
from vsegen.model import signals

VEHICLE_FILE = Path("vehicles") / "car.toml"
CHANNEL_MAP = Path("channels.toml")
README = Path("README.md")
MAPPED_BY_DEFAULT = ("delta", "vx", "ax", "ay", "r")
"""Columns the example channel map names (the other columns are there as comments)."""


class StarterError(ValueError):
    """The starter project cannot be written (one line)."""


def vehicle_text(like: str) -> str:
    """The shipped vehicle file ``like`` (e.g. "c_class") under a header saying what to change."""
    name = f"{like}.toml"
    if name not in shipped_vehicle_names():
        choices = ", ".join(n.removesuffix(".toml") for n in shipped_vehicle_names())
        raise StarterError(f"--like {like}: no such shipped vehicle: expected one of {choices}")
    body = re.sub(r"^forms = \[[^\]]*\]\n", '# forms = ["switching:float-calibratable"]\n', shipped_vehicle(name),
                  flags=re.MULTILINE)      # vsegen's own reviewed forms are not the user's
    return (f"# Your car's vehicle file, started from vsegen's shipped {like}.toml: replace the values with\n"
            f"# your car's. `vsegen identify --log DRIVE --vehicle vehicles/car.toml --out vehicles/car.toml`\n"
            f"# derives mass-independent ones (cornering stiffness, roll gradient, sensor noise, ...) from\n"
            f"# test-drive logs; `vsegen tune` sets an estimator's settings. Every key is checked on load.\n"
            f"#\n" + body)


def channel_map_text() -> str:
    """A channel map naming every log column: the core inputs active (channel = the column's own
    name, SI unit), the rest commented out."""
    docs = {s.name: s.doc for s in (*(e.signal for e in signals.INPUTS), *signals.TRUTH)}
    lines = ["# Channel map: which logger channel holds each log column, in which unit (`vsegen docs` writes",
             "# conventions.md, 'Log format'). Units: rad, deg | m/s, km/h, mph | rad/s, deg/s, rpm | m/s^2, g | N*m",
             "# | - | s, ms, us. `group` or `message` choose an MDF4 channel whose name is in several groups.",
             "# `factor` (optional) is applied first, e.g. 1 / steering ratio for a steering-wheel angle.",
             "# A column left out is read from a channel of its own name, in SI units.",
             "# Use: vsegen run --log DRIVE.mf4 --channels channels.toml --estimator switching --out est.csv", ""]
    for name, unit in signals.LOG_COLUMN_UNITS.items():
        mark = "" if name in MAPPED_BY_DEFAULT else "# "
        lines += [f"# {name}: {docs.get(name, '')}".rstrip(),
                  f"{mark}[columns.{name}]", f'{mark}channel = "{name}"', f'{mark}unit = "{unit}"', ""]
    return "\n".join(lines)


def readme_text() -> str:
    return ("# vsegen project\n\n"
            "- `vehicles/car.toml`: your car (start from these values, then replace them).\n"
            "- `channels.toml`: how your logger's channels map to vsegen's log columns.\n\n"
            "Next, from this folder:\n\n"
            "```sh\n"
            "vsegen docs                          # conventions, log format, vehicle-file keys into docs/\n"
            "vsegen generate                      # C of every estimator into generated/car/\n"
            "vsegen verify --estimator kf2dof     # the C against the NumPy reference\n"
            "vsegen run --log DRIVE.mf4 --channels channels.toml --estimator switching --out est.csv\n"
            "```\n")


def init_project(folder: Path, like: str = "c_class") -> list[Path]:
    """Write the starter project into ``folder`` (created if needed); the files written."""
    files = {VEHICLE_FILE: vehicle_text(like), CHANNEL_MAP: channel_map_text(), README: readme_text()}
    existing = [folder / path for path in files if (folder / path).exists()]
    if existing:
        raise StarterError(f"{existing[0]}: already exists: expected a new or empty folder "
                           f"(vsegen init never overwrites)")
    for path, text in files.items():
        write_text_atomic(folder / path, text)
    return [folder / path for path in files]
