"""Registry of estimators: name -> builder(Parameters) -> Estimator."""

from __future__ import annotations

from collections.abc import Callable

from model.calibration import Parameters, parameters
from model.estimator import Estimator
from model.estimators import arx_dual_kf, aukf, ekf_rls, fusion, kf2dof, pf, switching
from model.params import VehicleConfig

BUILDERS: dict[str, Callable[[Parameters], Estimator]] = {
    kf2dof.NAME: kf2dof.build,
    switching.NAME: switching.build,
    fusion.NAME: fusion.build,
    arx_dual_kf.NAME: arx_dual_kf.build,
    ekf_rls.NAME: ekf_rls.build,
    aukf.PLAIN_NAME: aukf.build_plain,
    aukf.NAME: aukf.build_adaptive,
    pf.ADAPTIVE: pf.build_adaptive,
    pf.IMPROVED: pf.build_improved,
}


def build(name: str, config: VehicleConfig, params: str = "baked") -> Estimator:
    """Build estimator ``name`` for ``config`` with parameters ``params`` ("baked" or
    "calibratable"); KeyError if no such estimator exists."""
    return BUILDERS[name](parameters(config, name, params))
