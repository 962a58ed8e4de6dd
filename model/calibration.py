"""Parameters as baked constants or as a run-time calibration vector.

In *baked* mode every parameter is a number in the expressions, and CasADi folds them into the
generated code. In *calibratable* mode each numeric parameter an estimator reads ([vehicle],
[inputs] and its own [estimator.<name>] table; the sample time and the choices stay baked) is an
entry of a symbolic vector ``params``, the extra input of ``init`` and ``step``; the C reads it
from a const calibration struct. Decisions taken at generation time (the ZOH series length) use
the numeric values; in calibratable mode the series covers ||A|| up to CALIBRATION_MARGIN times the
generated value (one more squaring), so moderate recalibration keeps the stated accuracy.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import casadi as ca

if TYPE_CHECKING:    # annotations only: model.params imports the estimators, which import this
    from vsegen.model.params import VehicleConfig


CALIBRATION_MARGIN = 2.0
MODES = ("baked", "calibratable")


@dataclass(frozen=True)
class Parameters:
    """Where an estimator's parameter values come from.

    Attributes:
        numeric: the vehicle configuration with numbers (generation-time decisions).
        config: the same configuration as used in expressions: numbers (baked) or SX symbols.
        names: names of the calibration entries (empty when baked), e.g. ``mass``,
            ``process_noise_12``.
        values: their values (the generated calibration).
        symbols: the symbolic calibration vector, or None when baked.
        fixed: numeric values that stay baked in calibratable mode because the code reads them
            only at generation (structural: e.g. a window length) or not at all.
    """

    numeric: VehicleConfig
    config: VehicleConfig
    names: tuple[str, ...] = ()
    values: tuple[float, ...] = ()
    symbols: ca.SX | None = None
    fixed: tuple[str, ...] = ()

    @property
    def calibratable(self) -> bool:
        return self.symbols is not None

    @property
    def norm_margin(self) -> float:
        """Factor on norm bounds used for generation-time series plans."""
        return CALIBRATION_MARGIN if self.calibratable else 1.0

    def inputs(self) -> list[ca.SX]:
        """Extra Function inputs: [params] when calibratable, else none."""
        return [self.symbols] if self.calibratable else []

    def keyword(self) -> dict[str, ca.SX]:
        """The ``params`` keyword argument for calling a Function built with :meth:`inputs`."""
        return {"params": self.symbols} if self.calibratable else {}


def baked(config: VehicleConfig) -> Parameters:
    return Parameters(config, config)


class _Entry(int):
    """Index of a calibration entry (unlike a whole-number setting, which stays baked)."""


def calibratable(config: VehicleConfig, estimator: str,
                 only: tuple[str, ...] | None = None) -> Parameters:
    """Symbolic parameters for ``estimator``: one entry per numeric value it may read (a symmetric
    matrix contributes its upper triangle, named ``<key>_<row><column>``); with ``only``, just
    those entries, the other values baked (``Parameters.fixed``)."""
    entries: list[tuple[str, float]] = []
    fixed: list[str] = []

    def entry(name: str, value: float) -> _Entry | float:
        if only is not None and name not in only:
            fixed.append(name)
            return value
        entries.append((name, value))
        return _Entry(len(entries) - 1)

    vehicle = {k: entry(k, v) for k, v in config.vehicle.items()}
    limits = {k: entry(k, v) for k, v in config.limits.items()}
    settings: dict[str, Any] = {}
    for key, value in config.settings(estimator).items():
        if isinstance(value, tuple) and not isinstance(value[0], tuple):
            settings[key] = tuple(entry(f"{key}_{i + 1}", v) for i, v in enumerate(value))
        elif isinstance(value, tuple):
            n = len(value)
            upper = {(i, j): entry(f"{key}_{i + 1}{j + 1}", value[i][j])
                     for i in range(n) for j in range(i, n)}
            settings[key] = tuple(tuple(upper[min(i, j), max(i, j)] for j in range(n))
                                  for i in range(n))
        elif isinstance(value, float):
            settings[key] = entry(key, value)
        else:
            settings[key] = value  # a choice or a count (e.g. the discretisation) stays baked
    vector = ca.SX.sym("params", len(entries))

    def symbolic(value):
        if isinstance(value, tuple):
            return tuple(symbolic(v) for v in value)
        return vector[value] if isinstance(value, _Entry) else value

    config_symbolic = replace(
        config,
        vehicle=MappingProxyType({k: symbolic(i) for k, i in vehicle.items()}),
        limits=MappingProxyType({k: symbolic(i) for k, i in limits.items()}),
        estimators=MappingProxyType({**config.estimators, estimator: MappingProxyType(
            {k: symbolic(v) for k, v in settings.items()})}),
    )
    return Parameters(config, config_symbolic, tuple(n for n, _ in entries),
                      tuple(v for _, v in entries), vector, tuple(fixed))


def calibration_values(config: VehicleConfig, estimator: str,
                       names: tuple[str, ...]) -> tuple[float, ...]:
    """The values ``config`` gives the calibration entries ``names`` (e.g. a built estimator's
    ``parameters.names``, for a candidate file of ``vsegen tune``)."""
    full = calibratable(config, estimator)
    table = dict(zip(full.names, full.values))
    return tuple(table[name] for name in names)


def parameters(config: VehicleConfig, estimator: str, mode: str) -> Parameters:
    """Parameters of ``estimator`` in ``mode`` ("baked" or "calibratable")."""
    if mode not in MODES:
        raise ValueError(f"parameter mode {mode!r}: expected one of {MODES}")
    return calibratable(config, estimator) if mode == "calibratable" else baked(config)


def matrix(rows) -> ca.SX:
    """An SX matrix from nested rows of numbers or SX scalars."""
    return ca.vertcat(*[ca.horzcat(*row) for row in rows])
