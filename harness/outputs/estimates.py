"""Estimates files, as ``vsegen run`` writes them and ``score`` and ``plot`` read them: CSV, ASAM
MDF4 when the name ends in .mf4/.mdf, Parquet when it ends in .parquet, with ``t`` and the
estimator's outputs in SI units. An MDF4 file carries each channel's unit; on reading, a unit of
the vocabulary of channel maps is converted to SI, and a unit of the wrong kind or an unknown one
is refused in one line."""

from __future__ import annotations

import queue
import threading
from collections.abc import Iterator, Mapping
from contextlib import ExitStack
from pathlib import Path

import numpy as np

from vsegen.harness.logs.channels import SI_KIND, UNITS
from vsegen.harness.logs.mdf import SUFFIXES, open_mdf
from vsegen.harness.logs.stream import LogSource, arrow_floats, open_csv_log
from vsegen.harness.logs.table import ESTIMATED, Log, LogError
from vsegen.harness.project.files import atomic_path

PARQUET = ".parquet"
KNOWN_UNITS = {"beta": "rad", "beta_ekf": "rad", "beta_int": "rad", "vx": "m/s", "vy": "m/s", "r": "rad/s",
               "ax": "m/s^2", "ay": "m/s^2", "yaw_moment": "N*m", "status": "-", "mode": "-"}
"""The SI unit of the outputs ``score`` and ``plot`` read (others are kept as they are)."""


class EstimatesWriter:
    """Estimates written chunk by chunk (``with EstimatesWriter(path, units) as out: out.write(chunk)``):
    CSV (shortest round-trip decimals, as pyarrow writes them), MDF4 (.mf4/.mdf, each channel with
    its unit from ``units``) or Parquet (.parquet), by suffix. A background thread writes while
    the caller computes the next chunk (pyarrow releases the GIL). The file appears, whole, only
    when the ``with`` block ends without an error."""

    def __init__(self, path: Path, units: Mapping[str, str]):
        self.path = Path(path)
        self.units = units
        self.kind = "mdf" if self.path.suffix.lower() in SUFFIXES else \
            "parquet" if self.path.suffix.lower() == PARQUET else "csv"
        self.samples = 0

    def __enter__(self) -> EstimatesWriter:
        self._stack = ExitStack()
        self._tmp = self._stack.enter_context(atomic_path(self.path))
        self._writer = None
        self._queue: queue.Queue = queue.Queue(maxsize=2)
        self._failure: BaseException | None = None
        self._thread = threading.Thread(target=self._drain, name=f"write {self.path}", daemon=True)
        self._thread.start()
        return self

    def write(self, chunk: Log) -> None:
        """Append the next chunk (the same columns every time)."""
        if self._failure is not None:
            raise self._failure
        self._queue.put(chunk)
        self.samples += len(chunk)

    def _drain(self) -> None:
        while (chunk := self._queue.get()) is not None:
            if self._failure is None:
                try:
                    self._write(chunk)
                except BaseException as exc:  # raised in the caller's thread
                    self._failure = exc

    def _write(self, chunk: Log) -> None:
        import pyarrow as pa

        if self.kind == "mdf":
            self._write_mdf(chunk)
            return
        batch = pa.RecordBatch.from_arrays([arrow_floats(values) for values in chunk.columns.values()],
                                           names=list(chunk.columns))
        if self._writer is None:
            self._writer = self._open_arrow(batch.schema)
        self._writer.write_batch(batch)

    def _open_arrow(self, schema):
        import pyarrow.csv as pacsv
        import pyarrow.parquet as pq

        if self.kind == "parquet":
            return pq.ParquetWriter(self._tmp, schema)
        handle = self._stack.enter_context(open(self._tmp, "wb"))
        handle.write((",".join(schema.names) + "\n").encode())
        return pacsv.CSVWriter(handle, schema, write_options=pacsv.WriteOptions(include_header=False,
                                                                                quoting_style="none"))

    def _write_mdf(self, chunk: Log) -> None:
        from asammdf import MDF, Signal

        names = [name for name in chunk.columns if name != "t"]
        if self._writer is None:
            self._writer = MDF(version="4.10")
            self._writer.append([Signal(np.asarray(chunk[name], dtype=float), chunk["t"], name=name,
                                        unit=self.units.get(name, "")) for name in names], common_timebase=True)
        else:
            self._writer.extend(0, [(np.asarray(chunk["t"], dtype=float), None),
                                    *((np.asarray(chunk[name], dtype=float), None) for name in names)])

    def __exit__(self, kind, value, traceback) -> None:
        self._queue.put(None)
        self._thread.join()
        try:
            if kind is None and self._failure is not None:
                raise self._failure
            if kind is None and self._writer is None:
                raise LogError(f"{self.path}: no estimates to write")
            if self._writer is not None:
                if self.kind == "mdf" and kind is None:
                    self._writer.save(self._tmp, overwrite=True)
                self._writer.close()
        finally:
            self._stack.__exit__(kind, value, traceback)


def read_estimates(path: Path) -> Log:
    """An estimates file: ``t``, at least one of ``beta``, ``vy``, ``r``, and other numeric columns,
    in SI units; LogError (one line) otherwise."""
    return open_estimates(path).read()


def open_estimates(path: Path) -> LogSource:
    """An estimates file (CSV, MDF4 or Parquet, as :func:`read_estimates` takes) as a source of chunks."""
    if Path(path).suffix.lower() in SUFFIXES:
        source = _open_mdf_estimates(path)
    elif Path(path).suffix.lower() == PARQUET:
        source = _open_parquet_estimates(path)
    else:
        source = open_csv_log(path, required=("t",), all_numeric=True)
    if not any(name in source.names for name in ESTIMATED):
        raise LogError(f"{path}:1: no estimated signal: expected a column {', '.join(ESTIMATED[:-1])} "
                       f"or {ESTIMATED[-1]} (found {', '.join(source.names)})")
    return source


def _open_mdf_estimates(path: Path) -> LogSource:
    """The estimates of an MDF4 file (each channel's first occurrence, converted to SI), read in
    ranges of records: the channels of `vsegen run --out EST.mf4` share one time base."""
    mdf = open_mdf(path)
    channels: dict[str, tuple[int, int, float]] = {}
    for name in mdf.channels_db:
        if name in ("t", "time") or name.startswith("$") or name in channels:
            continue
        group, index = mdf.channels_db[name][0]
        unit = str(mdf.get(name, group, index, record_offset=0, record_count=1).unit or "")
        channels[name] = (group, index, _to_si(path, name, unit))
    groups = {group for group, _, _ in channels.values()}
    if len(groups) != 1:
        mdf.close()
        raise LogError(f"{path}: {len(groups)} channel groups: expected the estimates of `vsegen run --out EST.mf4` "
                       "(one group of channels on one time base)")
    group = groups.pop()
    records = int(mdf.groups[group].channel_group.cycles_nr)
    if records < 2:
        mdf.close()
        raise LogError(f"{path}: {records} record(s): expected at least 2")
    head = mdf.get(next(iter(channels)), group, channels[next(iter(channels))][1], record_offset=0, record_count=2)
    last = mdf.get(next(iter(channels)), group, channels[next(iter(channels))][1], record_offset=records - 1,
                   record_count=1)
    sample_time = float((last.timestamps[-1] - head.timestamps[0]) / (records - 1))

    def chunks(rows: int, names: tuple[str, ...]) -> Iterator[Log]:
        for offset in range(0, records, rows):
            columns: dict[str, np.ndarray] = {}
            wanted = names[1:]
            for name in wanted or (next(iter(channels)),):
                _, index, factor = channels[name]
                signal = mdf.get(name, group, index, record_offset=offset, record_count=rows)
                columns.setdefault("t", np.asarray(signal.timestamps, dtype=float))
                if name in wanted:
                    columns[name] = np.asarray(signal.samples, dtype=float) * factor
            yield Log({"t": columns.pop("t"), **columns}, str(path))

    return LogSource(str(path), sample_time, records, ("t", *channels), chunks, closers=[mdf.close])


def _open_parquet_estimates(path: Path) -> LogSource:
    """The estimates of a Parquet file (``vsegen run --out EST.parquet``), read a record batch at a
    time: every numeric column, ``t`` first."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        parquet = pq.ParquetFile(path)
    except (OSError, pa.ArrowException) as exc:
        raise LogError(f"{path}: not a Parquet file ({str(exc).splitlines()[0]})") from None
    schema = parquet.schema_arrow
    numeric = tuple(f.name for f in schema if pa.types.is_floating(f.type) or pa.types.is_integer(f.type))
    if "t" not in numeric:
        raise LogError(f"{path}: no numeric column 't': expected the estimates of `vsegen run --out EST.parquet`")
    samples = parquet.metadata.num_rows
    if samples < 2:
        raise LogError(f"{path}: {samples} row(s): expected at least 2")
    t = parquet.read(columns=["t"]).column("t").to_numpy()
    sample_time = float((t[-1] - t[0]) / (samples - 1))

    def chunks(rows: int, names: tuple[str, ...]) -> Iterator[Log]:
        for batch in parquet.iter_batches(batch_size=rows, columns=list(names)):
            yield Log({name: batch.column(name).to_numpy(zero_copy_only=False).astype(float) for name in names},
                      str(path))

    return LogSource(str(path), sample_time, samples, ("t", *(n for n in numeric if n != "t")), chunks,
                     closers=[parquet.close])


def _to_si(path: Path, name: str, unit: str) -> float:
    """The factor from a channel's ``unit`` to its column's SI unit (1 where either is unknown)."""
    si = KNOWN_UNITS.get(name)
    if si is None or unit in ("", si):
        return 1.0
    if unit not in UNITS or UNITS[unit][0] != SI_KIND.get(si):
        raise LogError(f"{path}: channel '{name}' unit = {unit!r}: expected a unit of {SI_KIND.get(si, si)} "
                       f"(the column is in {si})")
    return UNITS[unit][1]

