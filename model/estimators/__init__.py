"""The estimators: one registry derived from the list of estimator modules. Each module declares
``DEFINITIONS`` (``model.estimator.Definition``: name, builder, settings schema, tunable
settings); adding an estimator adds its module here (CONTRIBUTING.md)."""

from __future__ import annotations

from collections import OrderedDict
from typing import TYPE_CHECKING

from vsegen.model.calibration import calibratable, parameters
from vsegen.model.estimator import Definition, Estimator
from vsegen.model.estimators import arx_dual_kf, aukf, ekf_rls, fusion, kf2dof, pf, switching
from vsegen.model.schema import EstimatorSchema, shown

if TYPE_CHECKING:
    from vsegen.model.params import VehicleConfig

MODULES = (kf2dof, switching, fusion, arx_dual_kf, ekf_rls, aukf, pf)
DEFINITIONS: dict[str, Definition] = {d.name: d for module in MODULES for d in module.DEFINITIONS}
"""Every estimator by name, in the order of MODULES (the order of tables and reports)."""
SCHEMAS: dict[str, EstimatorSchema] = {name: d.schema for name, d in DEFINITIONS.items()}


BUILT_KEPT = 8
"""Estimators kept built (the last ones asked for): one command asks for the same one several
times (its inputs, its reference run, its C, its kit), and a build takes a good fraction of a second."""
_built: OrderedDict[tuple[str, str, str], Estimator] = OrderedDict()


def build(name: str, config: VehicleConfig, params: str = "baked") -> Estimator:
    """Build estimator ``name`` for ``config`` with parameters ``params`` ("baked" or
    "calibratable"); KeyError if no such estimator exists. A calibratable estimator's calibration
    holds only what its code reads at run time: values read only at generation (structural) or not
    at all are baked and listed in ``parameters.fixed``. The last BUILT_KEPT are kept, by the
    configuration's fingerprint (an Estimator is never changed once built)."""
    key = (config.fingerprint(), name, params)
    if key not in _built:
        _built[key] = build_fresh(name, config, params)
        while len(_built) > BUILT_KEPT:
            _built.popitem(last=False)
    _built.move_to_end(key)
    return _built[key]


def build_fresh(name: str, config: VehicleConfig, params: str = "baked") -> Estimator:
    """:func:`build`, built anew (not one kept): for a build that must run its model code, e.g.
    under ``harness.verify.decision_sites.traced``."""
    definition = DEFINITIONS[name]
    estimator = definition.build(parameters(config, name, params))
    if params == "calibratable":
        read = estimator.read_parameters()
        if len(read) < len(estimator.parameters.names):
            estimator = definition.build(calibratable(config, name, read))
    return estimator


def monitor_only_inputs(config: VehicleConfig, name: str) -> tuple[str, ...]:
    """The inputs only an input monitor of ``name`` reads (the yaw-rate check's a_x and wheel
    speeds where the method does not read them): an implausible one does not hold the estimator
    (``model.guard.input_guard``), and a log may lack them (the check is then off)."""
    monitors = DEFINITIONS[name].monitors
    return monitors(config.settings(name)).monitored if monitors else ()


def underived_warning(config: VehicleConfig, name: str) -> str | None:
    """A one-line warning when ``name``'s car-specific settings (``Definition.derived``) were not
    derived for ``config``'s [vehicle] table (``[estimator] derived_for`` differs from its
    fingerprint, e.g. a file copied from another car with only [vehicle] changed); else None."""
    derived = [key for key, rule in DEFINITIONS[name].derived.items() if not rule.optional]
    fingerprint = config.vehicle_fingerprint()
    if not derived or name not in config.estimators or config.derived_for == fingerprint:
        return None
    settings = config.settings(name)
    listed = ", ".join(f"{key} = {shown(settings[key])}" for key in derived)
    verb = "was" if len(derived) == 1 else "were"
    return (f"{config.source}: warning: [estimator.{name}] {listed} {verb} not derived for this vehicle "
            f"(see vsegen identify; after a review set [estimator] derived_for = \"{fingerprint}\")")
