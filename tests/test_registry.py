"""The estimator registry: one list of estimator modules, each declaring its name, builder,
settings schema and tunable settings; the references bound to the same names."""

from __future__ import annotations

import numpy as np
import pytest
from locations import VEHICLES

from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.reference import LONG_DOUBLE, REFERENCES
from vsegen.model.estimators import DEFINITIONS, MODULES, SCHEMAS, build


def test_every_estimator_has_a_reference_and_nothing_else_has():
    assert list(REFERENCES) == list(DEFINITIONS)
    assert LONG_DOUBLE == {"ukf", "aukf"}


def test_the_registry_is_derived_from_the_modules():
    declared = [d.name for module in MODULES for d in module.DEFINITIONS]
    assert declared == list(DEFINITIONS) == list(SCHEMAS)
    assert len(set(declared)) == len(declared)


def read_calibration_entries(estimator) -> set[str]:
    """The calibration entries some kernel Function of ``estimator`` depends on (CasADi's
    which_depends on the ``params`` input): what the generated C reads at run time."""
    names = estimator.parameters.names
    read = set()
    for function in (estimator.init, *estimator.structure.kernel_functions):
        inputs = [function.name_in(i) for i in range(function.n_in())]
        if "params" not in inputs:
            continue
        for output in range(function.n_out()):
            flags = function.which_depends("params", [function.name_out(output)], 1, False)
            read |= {names[i] for i, flag in enumerate(flags) if flag}
    return read


@pytest.mark.parametrize("name", list(DEFINITIONS))
def test_tunable_settings_are_read_at_run_time_and_hold_the_shipped_values(config, name):
    definition = DEFINITIONS[name]
    keys = {f.key for f in definition.schema.fields}
    estimator = build(name, config, "calibratable")
    read = read_calibration_entries(estimator)
    settings = config.settings(name)
    for key, tunable in definition.tunable.items():
        assert key in keys, f"{name}: tunable {key} is not a setting"
        if not tunable.applies(settings):
            continue
        assert tunable.low < tunable.high and (not tunable.log or tunable.low > 0)
        assert any(n == key or n.startswith(key + "_") for n in read), \
            f"{name}: the generated code never reads {key} at run time, so tuning it would change nothing"
    for path in sorted(VEHICLES.glob("*.toml")):
        vehicle = load_vehicle(path)
        if name not in vehicle.estimators:
            continue
        for key, tunable in definition.tunable.items():
            if not tunable.applies(vehicle.settings(name)):
                continue                        # the file's code does not read it (tune leaves it)
            values = np.atleast_1d(np.asarray(vehicle.settings(name)[key], dtype=float))
            if values.ndim == 2:
                values = np.diag(values)
            assert np.all((tunable.low <= values) & (values <= tunable.high)), (path.name, key, values)
