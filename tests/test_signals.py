"""The signal catalogue is the one description of every log column and shared entry: estimators,
the guard, the log reader, the vehicle-file schema and the docs all take theirs from it."""

from __future__ import annotations

import pytest

from vsegen.harness.logs.table import LogError, read_log
from vsegen.harness.starter import reference_docs
from vsegen.model import signals, status
from vsegen.model.estimators import DEFINITIONS, build
from vsegen.model.guard import LIMIT_KEYS
from vsegen.model.schema import INPUT_LIMITS


def test_the_signal_page_shows_every_column_and_status_bit():
    page = reference_docs.signals_page()
    for name in ("t", *signals.LOG_COLUMN_UNITS):
        assert f"| `{name}` | " in page
    for bit in status.BITS:
        assert f"| {bit.value} | {bit.name} | " in page and bit.meaning.split("|")[0] in page


@pytest.mark.parametrize("name", list(DEFINITIONS))
def test_estimators_read_catalogue_inputs_and_report_the_catalogue_status(config, name):
    estimator = build(name, config)
    for signal in estimator.inputs.signals:
        assert signal == signals.INPUT[signal.name].signal, f"{name}: input {signal.name} redefined"
    assert estimator.outputs.signals[-1] == signals.STATUS
    hold_entries = [s for s in estimator.states.signals if s in (signals.HOLDING, signals.HOLD_REASON,
                                                                 signals.LOW_SPEED_HOLD)]
    assert len(hold_entries) == 1


def test_every_input_has_a_limit_in_the_vehicle_schema():
    keys = {f.key for f in INPUT_LIMITS}
    assert set(LIMIT_KEYS.values()) == keys
    assert set(LIMIT_KEYS) == set(signals.INPUT)


@pytest.mark.parametrize("entry", [e for e in signals.INPUTS if e.unit_check], ids=lambda e: e.name)
def test_the_reader_checks_each_catalogued_unit(tmp_path, entry):
    columns = ["t", *signals.REQUIRED_INPUTS]
    value = {name: 1.0 if name == "vx" else 0.0 for name in columns}
    rows = []
    for k in range(20):
        row = {**value, "t": 0.01 * k, entry.name: 1.5 * entry.unit_check.limit}
        rows.append(",".join(repr(row[c]) for c in columns))
    path = tmp_path / "log.csv"
    path.write_text(",".join(columns) + "\n" + "\n".join(rows) + "\n")
    with pytest.raises(LogError, match=f"column '{entry.name}'.*{entry.unit_check.hint}"):
        read_log(path)


def test_the_reference_writes_the_model_status_bits():
    """The reference defines its status bits itself (it never imports the model); every one it
    defines has the model's value, and it defines every bit an estimator declares (the calibration
    check is C-only)."""
    from vsegen.harness.reference import blocks

    model_bits = {bit.name: bit.value for bit in status.BITS}
    reference_bits = {name: getattr(blocks, name) for name in model_bits if hasattr(blocks, name)}
    assert reference_bits == {name: model_bits[name] for name in reference_bits}
    declared = {status.BY_VALUE[value].name for d in DEFINITIONS.values() for value in d.status_bits}
    assert declared <= set(reference_bits)


def test_the_reference_watches_the_model_frozen_channels():
    """The frozen-signal monitor's channels are written in both (the reference never imports the
    model); they must agree."""
    from vsegen.harness.reference.input_checks import frozen as reference
    from vsegen.model.input_checks import frozen

    assert reference.CHANNELS == frozen.CHANNELS


def test_the_reference_crosschecks_the_model_inputs():
    """The cross-checks' inputs are written in both; they must agree."""
    from vsegen.harness.reference.input_checks import crosscheck as reference
    from vsegen.model.input_checks import crosscheck

    assert reference.INPUTS == crosscheck.INPUTS
