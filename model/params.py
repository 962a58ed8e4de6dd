"""Vehicle files: parse, validate and canonicalise.

A vehicle file is TOML text (see ``vehicles/c_class.toml``). This module turns that text into a
frozen :class:`VehicleConfig` or raises :class:`ParameterError` whose message is one line naming
the file, the line, the key, the offending value and what was expected. It is pure: the caller reads
the file and passes its text (``model/`` does no I/O).

Units are SI throughout; every field states its unit in :mod:`model.schema`.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

from vsegen.model.estimators import SCHEMAS
from vsegen.model.schema import (
    CODEGEN,
    INPUT_LIMITS,
    PLANT,
    SAMPLING,
    SENSORS,
    VEHICLE,
    Field,
    Invalid,
)

WHEELBASE_TOLERANCE = 1e-3
"""Allowed |a + b - l| in metres."""


class ParameterError(ValueError):
    """A vehicle file is wrong; the message is one line: ``file:line: [table] key = value: expected ...``."""


@dataclass(frozen=True)
class VehicleConfig:
    """A validated vehicle file.

    Attributes:
        name: vehicle name (the file stem), used for folder and symbol naming.
        source: where the text came from (for messages only).
        vehicle: physical parameters, SI units, keys of :data:`model.schema.VEHICLE`.
        limits: plausibility limits of the inputs shared by all estimators.
        sample_time: estimator sample time T in s.
        estimators: per estimator name, its validated settings.
        plant: the truth plant's parameters ([plant], simulation only), or None.
        sensors: the simulated sensors' parameters ([sensors]), or None.
        codegen: generation defaults ([codegen]): ``real``, ``params`` and the other ``forms``
            flashed, a tuple of (estimator, real, params).
    """

    name: str
    source: str
    vehicle: Mapping[str, float]
    limits: Mapping[str, float]
    sample_time: float
    estimators: Mapping[str, Mapping[str, Any]]
    plant: Mapping[str, Any] | None = None
    sensors: Mapping[str, float] | None = None
    codegen: Mapping[str, Any] = field(
        default_factory=lambda: MappingProxyType({f.key: f.default for f in CODEGEN}))
    derived_for: str = ""
    """``[estimator] derived_for``: the :meth:`vehicle_fingerprint` the car-specific settings were
    derived for ('' = never)."""

    def settings(self, estimator: str) -> Mapping[str, Any]:
        """Settings of one estimator; raises ParameterError if the file has none."""
        if estimator not in self.estimators:
            raise ParameterError(
                f"{self.source}: no [estimator.{estimator}] table: expected one of "
                f"{sorted(self.estimators)}"
            )
        return self.estimators[estimator]

    def with_sample_time(self, sample_time: float) -> VehicleConfig:
        """The same vehicle for another sample time (e.g. that of a log)."""
        value = SAMPLING[0].check(sample_time)
        return replace(self, sample_time=value)

    def with_settings(self, estimator: str, **changes: Any) -> VehicleConfig:
        """The same vehicle with some of ``estimator``'s settings changed (values as the schema
        holds them; not checked again)."""
        settings = MappingProxyType({**self.settings(estimator), **changes})
        return replace(self, estimators=MappingProxyType({**self.estimators, estimator: settings}))

    def canonical(self, estimator: str) -> dict[str, Any]:
        """Everything that determines ``estimator``'s generated code, as plain sorted data."""
        return {
            "vehicle_name": self.name,
            "vehicle": dict(sorted(self.vehicle.items())),
            "inputs": dict(sorted(self.limits.items())),
            "sample_time": self.sample_time,
            "estimator": estimator,
            "settings": _plain(self.settings(estimator)),
        }

    @property
    def driven_axle(self) -> str | None:
        """The axle the [plant] table says is driven ("front" or "rear"; None without [plant])."""
        return None if self.plant is None else self.plant.get("driven_axle")

    def fingerprint(self) -> str:
        """SHA-256 of the whole configuration (every table), e.g. to memoise simulations."""
        everything = {"name": self.name, "vehicle": dict(self.vehicle), "inputs": dict(self.limits),
                      "sample_time": self.sample_time, "plant": _plain(self.plant or {}),
                      "sensors": _plain(self.sensors or {}),
                      "estimators": {k: _plain(v) for k, v in self.estimators.items()}}
        text = json.dumps(everything, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    def vehicle_fingerprint(self) -> str:
        """The first 12 hex digits of the SHA-256 of the [vehicle] table: which car this is."""
        text = json.dumps(_plain(self.vehicle), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:12]

    def truth_fingerprint(self) -> str:
        """SHA-256 of the tables a simulation of this car reads ([vehicle], [plant], [sensors]):
        equal for two files that differ only in estimator settings, limits or sampling."""
        truth = {"vehicle": _plain(self.vehicle), "plant": _plain(self.plant or {}),
                 "sensors": _plain(self.sensors or {})}
        text = json.dumps(truth, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    def __reduce__(self):
        """Pickle as plain data (read-only mappings do not pickle), e.g. for worker processes."""
        return (_unpickle, ({name: _thawed(getattr(self, name))
                             for name in self.__dataclass_fields__},))

    def parameter_hash(self, estimator: str) -> str:
        """SHA-256 (hex) of :meth:`canonical` serialised as sorted JSON with exact float reprs."""
        text = json.dumps(self.canonical(estimator), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()


def parse_vehicle(text: str, source: str, name: str) -> VehicleConfig:
    """Validate the TOML ``text`` of a vehicle file.

    Args:
        text: the file's content.
        source: the file's path as the user named it (used in messages).
        name: the vehicle name (normally the file stem).
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(f"{source}: not valid TOML: {exc}") from None
    where = _Locator(text, source)
    _reject_unknown(data, {"vehicle", "inputs", "estimator", "plant", "sensors", "codegen"}, (), where)
    vehicle = _table(data, ("vehicle",), VEHICLE, where)
    _check_wheelbase(vehicle, where)
    limits = _table(data, ("inputs",), INPUT_LIMITS, where)
    estimator_data = data.get("estimator")
    if not isinstance(estimator_data, dict):
        raise ParameterError(f"{where.at(('estimator',))}: missing table [estimator]: expected "
                             f"sample_time and one [estimator.<name>] table per estimator")
    _reject_unknown(estimator_data, {f.key for f in SAMPLING} | set(SCHEMAS), ("estimator",), where)
    sampling = _fields(estimator_data, ("estimator",), SAMPLING, where)
    estimators = {}
    for est_name, schema in SCHEMAS.items():
        if est_name in estimator_data:
            settings = _table(data, ("estimator", est_name), schema.fields, where)
            for rule in schema.rules:
                problem = rule.check(settings)
                if problem:
                    raise ParameterError(f"{where.at(('estimator', est_name, rule.key))}: "
                                         f"[estimator.{est_name}] {problem}")
            estimators[est_name] = MappingProxyType(settings)
    if not estimators:
        raise ParameterError(f"{where.at(('estimator',))}: no estimator settings: expected at least "
                             f"one of {', '.join(f'[estimator.{n}]' for n in SCHEMAS)}")
    optional = {key: MappingProxyType(_table(data, (key,), fields, where)) if key in data else None
                for key, fields in (("plant", PLANT), ("sensors", SENSORS))}
    codegen_table = data.get("codegen", {})
    if not isinstance(codegen_table, dict):
        raise ParameterError(f"{where.at(('codegen',))}: [codegen] is not a table")
    _reject_unknown(codegen_table, {f.key for f in CODEGEN}, ("codegen",), where)
    codegen = _fields(codegen_table, ("codegen",), CODEGEN, where)
    for form in codegen["forms"]:
        if form[0] not in estimators:
            raise ParameterError(f"{where.at(('codegen', 'forms'))}: [codegen] forms names {form[0]}: expected "
                                 f"an estimator the file configures ({', '.join(estimators)})")
    return VehicleConfig(
        codegen=MappingProxyType(codegen),
        name=name,
        source=source,
        vehicle=MappingProxyType(vehicle),
        limits=MappingProxyType(limits),
        sample_time=sampling["sample_time"],
        derived_for=sampling["derived_for"],
        estimators=MappingProxyType(estimators),
        **optional,
    )


# --------------------------------------------------------------------------------------------
# validation helpers


def _table(data: dict, path: tuple[str, ...], fields: tuple[Field, ...], where: _Locator) -> dict:
    node: Any = data
    for part in path:
        if not isinstance(node, dict) or part not in node:
            raise ParameterError(f"{where.at(path)}: missing table [{'.'.join(path)}]: expected keys "
                                 f"{', '.join(f.key for f in fields)}")
        node = node[part]
    if not isinstance(node, dict):
        raise ParameterError(f"{where.at(path)}: [{'.'.join(path)}] is not a table")
    _reject_unknown(node, {f.key for f in fields}, path, where)
    return _fields(node, path, fields, where)


def _fields(node: dict, path: tuple[str, ...], fields: tuple[Field, ...], where: _Locator) -> dict:
    values = {}
    table = ".".join(path)
    for spec in fields:
        if spec.key not in node and spec.default is not None:
            values[spec.key] = spec.default
            continue
        if spec.key not in node:
            raise ParameterError(f"{where.at(path)}: [{table}] missing key '{spec.key}': expected "
                                 f"{spec.expected}")
        try:
            values[spec.key] = spec.check(node[spec.key])
        except Invalid as exc:
            raise ParameterError(f"{where.at((*path, spec.key))}: [{table}] {spec.key} = "
                                 f"{_show(node[spec.key])}: expected {exc}") from None
    return values


def _reject_unknown(node: dict, allowed: set[str], path: tuple[str, ...], where: _Locator) -> None:
    for key in node:
        if key not in allowed:
            table = f"[{'.'.join(path)}] " if path else ""
            raise ParameterError(f"{where.at((*path, key))}: {table}unknown key '{key}': expected one "
                                 f"of {', '.join(sorted(allowed))}")


def _check_wheelbase(vehicle: dict, where: _Locator) -> None:
    a, b, l = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"], vehicle["wheelbase"]
    if abs(a + b - l) > WHEELBASE_TOLERANCE:
        raise ParameterError(
            f"{where.at(('vehicle', 'wheelbase'))}: [vehicle] wheelbase = {l!r}: expected "
            f"cg_to_front_axle + cg_to_rear_axle = {a + b!r} m within {WHEELBASE_TOLERANCE} m"
        )


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _thawed(value: Any) -> Any:
    """``value`` with every read-only mapping (recursively) a dict, for pickling."""
    if isinstance(value, MappingProxyType):
        return {k: _thawed(v) for k, v in value.items()}
    return value


def _frozen(value: Any) -> Any:
    """The inverse of :func:`_thawed`."""
    if isinstance(value, dict):
        return MappingProxyType({k: _frozen(v) for k, v in value.items()})
    return value


def _unpickle(fields: dict[str, Any]) -> VehicleConfig:
    return VehicleConfig(**{k: _frozen(v) for k, v in fields.items()})


def _plain(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in sorted(value.items())}
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError("non-finite value in a validated configuration")
    return value


class _Locator:
    """Finds the line of a table or key in TOML text, for messages (best effort, 1-based)."""

    _HEADER = re.compile(r"^\s*\[\s*([A-Za-z0-9_.\- ]+?)\s*\]\s*(#.*)?$")
    _KEY = re.compile(r"^\s*([A-Za-z0-9_\-]+)\s*=")

    def __init__(self, text: str, source: str) -> None:
        self.source = source
        self.lines: dict[tuple[str, ...], int] = {}
        table: tuple[str, ...] = ()
        for number, line in enumerate(text.splitlines(), start=1):
            header = self._HEADER.match(line)
            if header:
                table = tuple(p.strip() for p in header.group(1).split("."))
                self.lines.setdefault(table, number)
                continue
            key = self._KEY.match(line)
            if key:
                self.lines.setdefault((*table, key.group(1)), number)

    def at(self, path: tuple[str, ...]) -> str:
        """``source:line`` of the longest known prefix of ``path`` (``source`` alone if none)."""
        for end in range(len(path), 0, -1):
            if path[:end] in self.lines:
                return f"{self.source}:{self.lines[path[:end]]}"
        return self.source
