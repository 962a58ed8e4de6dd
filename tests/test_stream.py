"""Streaming runs: a log read, run and written in chunks gives exactly what one pass gives, for the
C (double and float) and the reference, particle filters included; the fast CSV reader reads the
values the strict one reads and hands it every file it cannot take; MDF4 read in record ranges
equals MDF4 read whole; scores summed over chunks equal the scores of the whole log."""

from __future__ import annotations

import gzip

import numpy as np
import pytest
from test_channels import MAP, write_mf4

from vsegen.harness.host.build import compile_estimator
from vsegen.harness.host.run_log import EstimatorStream, estimator_inputs
from vsegen.harness.logs import mdf as mdf_module
from vsegen.harness.logs import stream as stream_module
from vsegen.harness.logs.channels import read_channel_map
from vsegen.harness.logs.mdf import open_mdf_log
from vsegen.harness.logs.stream import in_memory, open_csv_log
from vsegen.harness.logs.table import LogError, read_log, write_log
from vsegen.harness.outputs.estimates import EstimatesWriter, open_estimates
from vsegen.harness.score.metrics import score, score_sources
from vsegen.harness.sim.scenarios import Case

ODD_CHUNK = 333
"""Samples per chunk in these tests: not a divisor of any log's length, so the state crosses
boundaries mid-manoeuvre."""


@pytest.fixture(scope="module")
def dlc(config):
    return Case.of("dlc").simulate(config, 100.0, 1)


@pytest.mark.parametrize("name,real", [("kf2dof", "double"), ("switching", "float"), ("pf_improved", "double")])
def test_chunked_c_run_is_bit_identical_to_one_pass(config, dlc, name, real):
    estimator, compiled = compile_estimator(config, name, real, config.codegen["params"])
    whole, _ = compiled.run(estimator_inputs(estimator, dlc))
    stream = EstimatorStream(config, name, dlc.sample_time, "c", real)
    chunked = [stream(chunk) for chunk in in_memory(dlc).chunks(ODD_CHUNK)]
    for i, signal in enumerate(stream.output_names):
        np.testing.assert_array_equal(np.concatenate([c[signal] for c in chunked]), whole[:, i])


def test_chunked_reference_run_equals_one_pass(config, dlc):
    one = EstimatorStream(config, "ukf", dlc.sample_time, "reference")(dlc)
    stream = EstimatorStream(config, "ukf", dlc.sample_time, "reference")
    chunked = [stream(chunk) for chunk in in_memory(dlc).chunks(ODD_CHUNK)]
    for signal in stream.output_names:
        np.testing.assert_array_equal(np.concatenate([c[signal] for c in chunked]), one[signal])


@pytest.mark.parametrize("suffix", [".csv", ".csv.gz"])
def test_the_fast_csv_reader_reads_what_the_strict_one_reads(tmp_path, dlc, suffix, monkeypatch):
    monkeypatch.setattr(stream_module, "BLOCK_BYTES", 4096)   # pyarrow's blocks end mid-chunk
    path = tmp_path / "drive.csv"
    write_log(dlc, path)
    if suffix == ".csv.gz":
        path = tmp_path / "drive.csv.gz"
        path.write_bytes(gzip.compress((tmp_path / "drive.csv").read_bytes()))
    strict = read_log(path).window(1.0, 3.0)
    source = open_csv_log(path, window=(1.0, 3.0))
    assert source.samples == len(strict) and source.sample_time == strict.sample_time
    chunks = list(source.chunks(37))
    assert max(len(c) for c in chunks) == 37
    for name in source.names:
        np.testing.assert_array_equal(np.concatenate([c[name] for c in chunks]), strict[name])


def test_a_jittered_csv_is_left_to_the_strict_reader(tmp_path, dlc):
    jittered = dict(dlc.columns)
    jittered["t"] = dlc["t"] + np.where(np.arange(len(dlc)) % 7 == 3, 0.002, 0.0)
    path = tmp_path / "jittered.csv"
    write_log(type(dlc)(jittered), path)
    source = open_csv_log(path)
    assert "resampled" in source.notes
    np.testing.assert_array_equal(source.read()["ay"], read_log(path)["ay"])


@pytest.mark.parametrize("edit,fragment", [
    (lambda rows: rows.__setitem__(400, rows[400].replace(",", ",x", 1)), ":401: column 'delta'"),
    (lambda rows: rows.__setitem__(700, rows[700].rsplit(",", 2)[0]), ":701: "),
    (lambda rows: rows.__setitem__(slice(1, None), [_in_degrees(row) for row in rows[1:]]), "looks like degrees"),
])
def test_a_damaged_csv_gets_the_strict_readers_line(tmp_path, dlc, edit, fragment):
    path = tmp_path / "drive.csv"
    write_log(dlc, path)
    rows = path.read_text().splitlines()
    edit(rows)
    path.write_text("\n".join(rows) + "\n")
    with pytest.raises(LogError) as strict:
        read_log(path)
    with pytest.raises(LogError) as fast:
        list(open_csv_log(path).chunks(ODD_CHUNK))
    assert str(fast.value) == str(strict.value)
    assert fragment in str(fast.value)


def _in_degrees(row: str) -> str:
    """A log row with its delta (the second cell) in degrees."""
    cells = row.split(",")
    cells[1] = repr(float(np.degrees(float(cells[1]))) + 2.0)
    return ",".join(cells)


def test_mdf4_read_in_record_ranges_equals_mdf4_read_whole(tmp_path, dlc, monkeypatch):
    write_mf4(dlc, tmp_path / "drive.mf4")
    (tmp_path / "map.toml").write_text(MAP)
    channels = read_channel_map(tmp_path / "map.toml")
    whole = open_mdf_log(tmp_path / "drive.mf4", channels, 0.01).read()
    monkeypatch.setattr(mdf_module, "READ_RECORDS", 50)
    chunks = list(open_mdf_log(tmp_path / "drive.mf4", channels, 0.01).chunks(ODD_CHUNK))
    assert sum(len(c) for c in chunks) == len(whole) > 900
    for name in whole.columns:
        np.testing.assert_array_equal(np.concatenate([c[name] for c in chunks]), whole[name])


@pytest.mark.parametrize("suffix", [".csv", ".mf4", ".parquet"])
def test_estimates_written_in_chunks_read_back_exactly(tmp_path, config, dlc, suffix):
    stream = EstimatorStream(config, "kf2dof", dlc.sample_time)
    path = tmp_path / f"est{suffix}"
    parts = []
    with EstimatesWriter(path, {"beta": "rad"}) as writer:
        for chunk in in_memory(dlc).chunks(ODD_CHUNK):
            parts.append(stream(chunk))
            writer.write(parts[-1])
    back = open_estimates(path).read().columns
    for name in parts[0].columns:
        np.testing.assert_array_equal(back[name], np.concatenate([p[name] for p in parts]))


def test_mdf4_estimates_are_read_in_record_ranges(tmp_path, config, dlc):
    estimates = EstimatorStream(config, "kf2dof", dlc.sample_time)(dlc)
    with EstimatesWriter(tmp_path / "est.mf4", {"beta": "rad", "vy": "m/s", "r": "rad/s"}) as writer:
        writer.write(estimates)
    chunks = list(open_estimates(tmp_path / "est.mf4").chunks(ODD_CHUNK))
    assert [len(c) for c in chunks[:-1]] == [ODD_CHUNK] * (len(chunks) - 1)
    for name in estimates.columns:
        np.testing.assert_array_equal(np.concatenate([c[name] for c in chunks]), estimates[name])


def test_an_outside_reader_reads_mdf4_estimates_written_in_chunks(tmp_path, config, dlc):
    """mdfreader (not asammdf, which wrote the file) as an outside judge of the MDF4 that
    ``EstimatesWriter`` extends chunk by chunk."""
    import mdfreader

    estimates = EstimatorStream(config, "kf2dof", dlc.sample_time)(dlc)
    with EstimatesWriter(tmp_path / "est.mf4", {"beta": "rad", "vy": "m/s", "r": "rad/s"}) as writer:
        for chunk in in_memory(estimates).chunks(ODD_CHUNK):
            writer.write(chunk)
    judge = mdfreader.Mdf(str(tmp_path / "est.mf4"))
    for name in ("beta", "vy", "r", "status"):
        np.testing.assert_array_equal(judge.get_channel_data(name), estimates[name])
        np.testing.assert_array_equal(judge.get_channel_data(judge.get_channel_master(name)), estimates["t"])
    assert judge.get_channel_unit("beta") == "rad"


def test_a_failed_run_leaves_no_estimates_file(tmp_path, dlc):
    path = tmp_path / "est.csv"
    with pytest.raises(RuntimeError), EstimatesWriter(path, {}) as writer:
        writer.write(dlc)
        raise RuntimeError("estimator failed")
    assert list(tmp_path.iterdir()) == []


def test_scores_summed_over_chunks_equal_the_whole_logs(tmp_path, config, dlc):
    estimates = EstimatorStream(config, "switching", dlc.sample_time)(dlc)
    whole = score(dlc, estimates)
    log_source, estimate_source = in_memory(dlc), in_memory(estimates)
    log_source.chunks = lambda rows=ODD_CHUNK, names=None: in_memory(dlc).chunks(ODD_CHUNK)
    estimate_source.chunks = lambda rows=ODD_CHUNK, names=None: in_memory(estimates).chunks(ODD_CHUNK)
    chunked = score_sources(log_source, estimate_source).result()
    assert [s.signal for s in chunked] == [s.signal for s in whole]
    for a, b in zip(chunked, whole):
        assert a.samples == b.samples and a.max == b.max
        assert a.mean == pytest.approx(b.mean, rel=1e-12) and a.rmse == pytest.approx(b.rmse, rel=1e-12)
