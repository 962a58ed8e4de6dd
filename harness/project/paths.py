"""Where things live: the user's project (its vehicles/, generated/ and docs/ folders), the vehicle
files shipped with vsegen, and the build cache.

vsegen never writes where it is installed. It works in a *project*: the nearest of the current
directory and its parents that has a ``vehicles/`` folder (a vsegen checkout is one; ``vsegen init
DIR`` makes one). Outside any project the current directory stands in, with no vehicle files."""

from __future__ import annotations

import os
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

DEFAULT_VEHICLE_NAME = "c_class.toml"   # the default when a project has several vehicle files


class ProjectError(ValueError):
    """No vehicle file where one was needed (one line: where vsegen looked, what to do)."""


@dataclass(frozen=True)
class Project:
    """A project folder: vehicles/ (the vehicle TOML files), generated/ (the C), docs/ (reports)."""

    root: Path

    @property
    def vehicles(self) -> Path:
        return self.root / "vehicles"

    @property
    def generated(self) -> Path:
        return self.root / "generated"

    @property
    def reports(self) -> Path:
        return self.root / "docs"

    def vehicle_files(self) -> list[Path]:
        """The project's vehicle files, sorted by name."""
        return sorted(self.vehicles.glob("*.toml"))

    def required_vehicle_files(self) -> list[Path]:
        """:meth:`vehicle_files`; ProjectError (one line) when there is none."""
        files = self.vehicle_files()
        if not files:
            raise ProjectError(f"no vehicle file in {self.vehicles}: expected --vehicle FILE, or a project "
                               f"made by `vsegen init DIR`")
        return files

    def default_vehicle(self) -> Path:
        """The vehicle file used when a command is given none: the project's only vehicle file, else
        its vehicles/c_class.toml. ProjectError when there is neither."""
        files = self.required_vehicle_files()
        if len(files) == 1:
            return files[0]
        if self.vehicles / DEFAULT_VEHICLE_NAME in files:
            return self.vehicles / DEFAULT_VEHICLE_NAME
        raise ProjectError(f"{len(files)} vehicle files in {self.vehicles} and none is {DEFAULT_VEHICLE_NAME}: "
                           f"expected --vehicle FILE to choose one")


def project(start: Path | None = None) -> Project:
    """The project that ``start`` (default: the current directory) is in: the nearest of it and
    its parents with a vehicles/ folder, else ``start`` itself."""
    start = (start or Path.cwd()).resolve()
    for folder in (start, *start.parents):
        if (folder / "vehicles").is_dir():
            return Project(folder)
    return Project(start)


def shipped_vehicle(name: str) -> str:
    """Text of the vehicle file ``name`` (e.g. "c_class.toml") installed with vsegen."""
    return resources.files("vsegen.vehicles").joinpath(name).read_text()


def shipped_vehicle_names() -> list[str]:
    """File names of the vehicle files installed with vsegen."""
    return sorted(p.name for p in resources.files("vsegen.vehicles").iterdir() if p.name.endswith(".toml"))


def cache_dir() -> Path:
    """Build cache: $VSEGEN_CACHE, else $XDG_CACHE_HOME/vsegen, else ~/.cache/vsegen."""
    if os.environ.get("VSEGEN_CACHE"):
        return Path(os.environ["VSEGEN_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "vsegen"
