"""Malformed-input corpus (tests/corpus): every bad vehicle file and bad log gives one clear line
naming the file, a non-zero exit, no traceback, and no output left behind."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

CORPUS = Path(__file__).parent / "corpus"
EXPECTED = json.loads((CORPUS / "expected.json").read_text())


def test_corpus_is_complete():
    files = {str(p.relative_to(CORPUS)) for p in CORPUS.glob("*/*")}
    assert files == set(EXPECTED)


def assert_one_clear_line(result, path: Path, fragment: str) -> None:
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f"vsegen: error: {path}"), lines[0]
    assert fragment in lines[0], lines[0]
    assert "Traceback" not in result.output


@pytest.mark.parametrize("name", sorted(n for n in EXPECTED if n.startswith("vehicles/")))
def test_bad_vehicle_files(tmp_path, name, vsegen):
    path = CORPUS / name
    out = tmp_path / "out"
    assert_one_clear_line(vsegen("generate", "--vehicle", str(path), "--out", str(out)), path,
                          EXPECTED[name])
    assert not out.exists()
    assert_one_clear_line(vsegen("verify", "--vehicle", str(path)), path, EXPECTED[name])
    log = tmp_path / "log.csv"
    assert_one_clear_line(vsegen("simulate", "dlc", "--vehicle", str(path), "--out", str(log)),
                          path, EXPECTED[name])
    assert not log.exists()


@pytest.mark.parametrize("name", sorted(n for n in EXPECTED if n.startswith("logs/")))
def test_bad_logs(tmp_path, name, vsegen):
    path = CORPUS / name
    est = tmp_path / "est.csv"
    assert_one_clear_line(vsegen("run", "--log", str(path), "--estimator", "kf2dof", "--out", str(est)),
                          path, EXPECTED[name])
    assert not est.exists() and list(tmp_path.iterdir()) == []
    assert_one_clear_line(vsegen("score", "--log", str(path), "--est", str(path)), path,
                          EXPECTED[name])
    figure = tmp_path / "fig.png"
    assert_one_clear_line(vsegen("plot", "--log", str(path), "--est", str(path), "--out", str(figure)),
                          path, EXPECTED[name])
    assert not figure.exists()


@pytest.mark.parametrize("name", sorted(n for n in EXPECTED if n.startswith("units/")))
def test_unit_mistakes(tmp_path, name, vsegen):
    """Logs that pass every range check but whose physics says a unit is wrong (r in deg/s, the
    steering-wheel angle as delta, a_y in g): run refuses in one line naming the column and the
    likely cause, writes nothing, and runs with --no-unit-check."""
    path = CORPUS / name
    est = tmp_path / "est.csv"
    assert_one_clear_line(vsegen("run", "--log", str(path), "--estimator", "kf2dof", "--out", str(est)),
                          path, EXPECTED[name])
    assert list(tmp_path.iterdir()) == []
    forced = vsegen("run", "--log", str(path), "--estimator", "kf2dof", "--out", str(est), "--no-unit-check")
    assert forced.exit_code == 0 and est.is_file()


def _logger_log(folder: Path) -> Path:
    """A log as a logger names and scales it (the corpus channel maps' names and units): steady
    cornering, 2 s at 100 Hz."""
    rows = ["t,SteerWhlAng,VehSpd,LongAcc,LatAcc,YawRate"]
    rows += [f"{k / 100:.2f},15.5,72.0,0.0,0.102,2.865" for k in range(200)]
    path = folder / "logger.csv"
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize("name", sorted(n for n in EXPECTED if n.startswith("channels/")))
def test_bad_channel_maps(tmp_path, name, vsegen):
    """A channel map with a mistake: one line naming the map (or, for a channel the log lacks, the
    log) and the key, exit 2, nothing written."""
    path, log = CORPUS / name, _logger_log(tmp_path)
    est = tmp_path / "est.csv"
    result = vsegen("run", "--log", str(log), "--channels", str(path), "--estimator", "kf2dof",
                    "--out", str(est))
    blamed = log if name.endswith("missing_channel.toml") else path
    assert_one_clear_line(result, blamed, EXPECTED[name])
    assert sorted(tmp_path.iterdir()) == [log]


@pytest.mark.parametrize("name", sorted(n for n in EXPECTED if n.startswith("mdf/")))
def test_bad_mdf4_files(tmp_path, name, vsegen):
    """An MDF4 file that is empty, not MDF, truncated or lacks a channel: one line, exit 2, nothing
    written, no traceback (asammdf's own complaints included)."""
    path = CORPUS / name
    est = tmp_path / "est.csv"
    assert_one_clear_line(vsegen("run", "--log", str(path), "--estimator", "kf2dof", "--out", str(est)),
                          path, EXPECTED[name])
    assert list(tmp_path.iterdir()) == []
