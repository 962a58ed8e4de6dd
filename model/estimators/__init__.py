"""Registry of estimators: name -> builder(VehicleConfig) -> Estimator."""

from __future__ import annotations

from typing import Callable

from model.estimator import Estimator
from model.estimators import kf2dof
from model.params import VehicleConfig

BUILDERS: dict[str, Callable[[VehicleConfig], Estimator]] = {
    kf2dof.NAME: kf2dof.build,
}


def build(name: str, config: VehicleConfig) -> Estimator:
    """Build estimator ``name`` for ``config``; KeyError if no such estimator exists."""
    return BUILDERS[name](config)
