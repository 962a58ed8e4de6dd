"""Scenario and estimator subsets for the tests that repeat a check already made in full elsewhere."""

from vsegen.harness.sim.scenarios import VERIFICATION_SET
from vsegen.model.estimators import aukf, pf

DECISIVE = tuple(case for case in VERIFICATION_SET if case.label in (
    "dlc(outliers=True,speed_kmh=120.0)", "dlc(mu=0.5,speed_kmh=120.0)",
    "dlc(freeze=r:3:1,ay:5:1,ax:7:1,speed_kmh=80.0)", "low_speed", "invalid_inputs", "input_extremes"))
"""The verification scenarios that take the most decisions (outliers, the friction limit, frozen
inputs, the speed rule, implausible and extreme inputs): where a build for another target or a
wrapper could part from the C that verify checks on all of them."""
assert len(DECISIVE) == 6, "a decisive scenario was renamed in harness.sim.scenarios"

PARTICLE_FILTERS = tuple(definition.name for definition in pf.DEFINITIONS)
"""The particle filters: about 100,000 instructions a step, the heaviest runs of a check."""

UNSCENTED_FILTERS = tuple(definition.name for definition in aukf.DEFINITIONS)
"""The unscented filters (ukf, aukf): about 15,000 instructions a step, checked against a long-double
reference, the heaviest runs after the particle filters'."""
