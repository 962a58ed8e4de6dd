"""Logs read chunk by chunk, so that peak memory does not depend on a log's length (``vsegen run``,
``score`` and ``campaign``).

A :class:`LogSource` knows a log's sample time and length before it is read, and yields it as
:class:`~vsegen.harness.logs.table.Log` chunks of a fixed number of samples. A CSV log is read with
pyarrow's streaming CSV reader in two passes: the time column alone (sample time, uniform and
increasing time), then the columns an estimator needs. A file the fast path cannot take as it is
(a jittered or gappy clock to resample, a damaged cell, a missing column, an unreadable file) is
handed to the strict reader of :mod:`~vsegen.harness.logs.table`, which either names the problem
in one line or reads the log whole (a resampled log lives in memory). An MDF4 log is read channel
by channel in record ranges, each channel brought causally onto the estimator's grid as
:func:`~vsegen.harness.logs.mdf.read_mdf` does (which reads through this module).
"""

from __future__ import annotations

import bz2
import csv
import gzip
import io
import lzma
import queue
import threading
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vsegen.harness.logs.table import (
    OPTIONAL_INPUTS,
    REQUIRED,
    SAMPLE_TIME_JITTER,
    TRUTH,
    UNIT_CHECKS,
    Log,
    LogError,
    UnitRanges,
    read_log,
)

CHUNK_ROWS = 1 << 16
"""Samples per chunk: 65,536 (11 min at 100 Hz, about 5 MB for a log of ten columns)."""
BLOCK_BYTES = 1 << 20
"""Bytes pyarrow's CSV reader parses at a time (1 MiB: 4 MiB blocks read ahead cost 100 MB of memory)."""
OPENERS = {".gz": gzip.open, ".bz2": bz2.open, ".xz": lzma.open}


@dataclass
class LogSource:
    """A log to read in chunks of samples: where it comes from, its sample time (s), its length,
    its columns and what was done to it (``notes``, as :class:`Log`'s)."""

    source: str
    sample_time: float
    samples: int
    names: tuple[str, ...]
    read_chunks: Callable[[int, tuple[str, ...]], Iterator[Log]]
    notes: dict[str, str] = field(default_factory=dict)
    closers: list[Callable[[], None]] = field(default_factory=list)
    """What :meth:`close` releases (e.g. an open MDF4 file)."""

    def close(self) -> None:
        """Release the files the source holds open (a campaign's worker reads many logs)."""
        for closer in self.closers:
            closer()
        self.closers.clear()

    def __enter__(self) -> LogSource:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def chunks(self, rows: int = CHUNK_ROWS, names: tuple[str, ...] | None = None) -> Iterator[Log]:
        """The log in order, ``rows`` samples per chunk (the last one shorter), with ``t`` and the
        columns ``names`` (default: all) it has."""
        wanted = self.names if names is None else ("t", *(n for n in names if n in self.names and n != "t"))
        return self.read_chunks(rows, wanted)

    def prefetched(self, rows: int = CHUNK_ROWS, names: tuple[str, ...] | None = None) -> Iterator[Log]:
        """:meth:`chunks`, read ahead by a background thread that starts now, so the caller can
        prepare (e.g. build the estimator) and work on one chunk while the next is parsed (pyarrow
        and asammdf release the GIL while they parse); at most two chunks wait."""
        results: queue.Queue = queue.Queue(maxsize=2)
        done = object()
        stop = threading.Event()

        def read() -> None:
            try:
                for chunk in self.chunks(rows, names):
                    if stop.is_set():
                        return
                    results.put(chunk)
                results.put(done)
            except BaseException as exc:  # handed to the caller, raised there
                results.put(exc)

        thread = threading.Thread(target=read, name=f"read {self.source}", daemon=True)
        thread.start()

        def drain() -> Iterator[Log]:
            try:
                while (item := results.get()) is not done:
                    if isinstance(item, BaseException):
                        raise item
                    yield item
            finally:
                stop.set()
                while thread.is_alive():
                    try:
                        results.get(timeout=0.05)
                    except queue.Empty:
                        pass

        return drain()

    def read(self) -> Log:
        """The whole log in memory."""
        parts = list(self.chunks())
        return Log({name: np.concatenate([p[name] for p in parts]) for name in parts[0].columns}, self.source,
                   dict(self.notes))


def in_memory(log: Log) -> LogSource:
    """A log already in memory as a source."""

    def chunks(rows: int, names: tuple[str, ...]) -> Iterator[Log]:
        for start in range(0, len(log), rows):
            yield Log({name: log[name][start:start + rows] for name in names}, log.source)

    return LogSource(log.source, log.sample_time, len(log), tuple(log.columns), chunks, dict(log.notes))


def open_csv_log(path: Path, channels: Mapping[str, tuple[str, float]] | None = None,
                 required: tuple[str, ...] = REQUIRED, all_numeric: bool = False,
                 window: tuple[float | None, float | None] = (None, None)) -> LogSource:
    """A CSV log (plain, .gz, .bz2, .xz) as a source of chunks, its known columns (every column
    with ``all_numeric``) as floats, renamed and scaled by ``channels`` (logger column -> (log
    column, factor to SI)), cut to ``window`` (s). The values are those :func:`read_log` reads;
    LogError (one line, :func:`read_log`'s) on a bad file."""
    channels = dict(channels or {})
    try:
        return _fast_csv(Path(path), channels, required, all_numeric, window)
    except _NotFast:
        return in_memory(read_log(path, required, all_numeric, channels).window(*window))


class _NotFast(Exception):
    """The fast reader leaves this file to the strict one."""


def _fast_csv(path: Path, channels: dict, required: tuple[str, ...], all_numeric: bool,
              window: tuple[float | None, float | None]) -> LogSource:
    try:
        with _open(path) as handle:
            first = handle.readline().decode("utf-8")
    except (OSError, EOFError, ValueError, lzma.LZMAError, UnicodeDecodeError):
        raise _NotFast from None
    logged = [cell.strip() for cell in next(csv.reader(io.StringIO(first)), [])]
    header = [channels[cell][0] if cell in channels else cell for cell in logged]
    if len(set(header)) != len(header) or any(name not in header for name in required):
        raise _NotFast
    known = set(header) if all_numeric else set(REQUIRED) | set(OPTIONAL_INPUTS) | set(TRUTH)
    numeric = tuple(name for name in header if name in known)
    scale = {mapped: factor for cell, (mapped, factor) in channels.items() if cell in logged}
    samples, sample_time = _time_pass(path, header, window, scale, ranges=not all_numeric)

    def strict() -> None:
        read_log(path, required, all_numeric, channels)

    def chunks(rows: int, names: tuple[str, ...]) -> Iterator[Log]:
        return _value_pass(path, header, names, scale, window, rows, strict)

    return LogSource(str(path), sample_time, samples, numeric, chunks)


def _open(path: Path):
    return OPENERS.get(path.suffix.lower(), open)(path, "rb")


def _batches(path: Path, header: list[str], columns: tuple[str, ...]):
    """pyarrow record batches of ``columns`` (floats) of the CSV at ``path``; _NotFast on any
    complaint of pyarrow's."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    try:
        handle = _open(path)
        reader = pacsv.open_csv(
            handle,
            read_options=pacsv.ReadOptions(column_names=header, skip_rows=1, block_size=BLOCK_BYTES),
            convert_options=pacsv.ConvertOptions(column_types={name: pa.float64() for name in columns},
                                                 include_columns=list(columns), null_values=[],
                                                 strings_can_be_null=False))
        with handle:
            try:
                yield from reader
            finally:
                reader.close()    # join its read-ahead thread now: one alive at exit aborts Python (apache/arrow#34314)
    except (pa.ArrowException, OSError, EOFError, lzma.LZMAError):
        raise _NotFast from None


def _floats(array) -> np.ndarray:
    """A pyarrow float64 array without nulls as numpy (a view of its buffer: ``to_numpy`` would
    import pandas, a quarter of a second)."""
    return np.frombuffer(array.buffers()[1], dtype=np.float64, count=len(array), offset=array.offset * 8)


def arrow_floats(values: np.ndarray):
    """A numpy array as a pyarrow float64 array, sharing its memory (``pa.array`` would import
    pandas)."""
    import pyarrow as pa

    values = np.ascontiguousarray(values, dtype=np.float64)
    return pa.Array.from_buffers(pa.float64(), len(values), [None, pa.py_buffer(values)])


def _time_pass(path: Path, header: list[str], window: tuple[float | None, float | None],
               scale: Mapping[str, float], ranges: bool) -> tuple[int, float]:
    """(samples in ``window``, mean time step in s) from a pass over ``t`` and, with ``ranges``, the
    columns with a unit range check (UNIT_CHECKS, the strict reader's message); _NotFast unless the time is
    finite, strictly increasing and uniform within SAMPLE_TIME_JITTER (else the strict reader
    names the line, or resamples)."""
    count, first, last, low, high = 0, None, None, np.inf, -np.inf
    counts = UnitRanges(str(path))
    checked = ("t", *(name for name in UNIT_CHECKS if name in header and ranges))
    for batch in _batches(path, header, checked):
        counts.add({name: _floats(batch.column(i)) * scale.get(name, 1.0) for i, name in enumerate(checked)})
        t = _windowed(_floats(batch.column(0)), window)
        if not np.all(np.isfinite(t)):
            raise _NotFast
        if t.size:
            steps = np.diff(t) if last is None else np.diff(np.concatenate(([last], t)))
            if steps.size:
                low, high = min(low, float(steps.min())), max(high, float(steps.max()))
            first = t[0] if first is None else first
            last = t[-1]
            count += t.size
    if count < 2 or low <= 0:
        raise _NotFast
    mean = float((last - first) / (count - 1))
    if low < mean * (1 - SAMPLE_TIME_JITTER) or high > mean * (1 + SAMPLE_TIME_JITTER):
        raise _NotFast
    counts.check()
    return count, mean


def _windowed(t: np.ndarray, window: tuple[float | None, float | None]) -> np.ndarray:
    return t[_inside(t, window)]


def _inside(t: np.ndarray, window: tuple[float | None, float | None]) -> np.ndarray:
    keep = np.ones(len(t), dtype=bool)
    if window[0] is not None:
        keep &= t >= window[0]
    if window[1] is not None:
        keep &= t <= window[1]
    return keep


def _value_pass(path: Path, header: list[str], numeric: tuple[str, ...], scale: Mapping[str, float],
                window: tuple[float | None, float | None], rows: int, strict: Callable[[], None]) -> Iterator[Log]:
    """The chunks of the second pass; a cell pyarrow cannot read is named by the ``strict`` reader."""
    pending: list[dict[str, np.ndarray]] = []
    held = 0
    try:
        for batch in _batches(path, header, numeric):
            columns = {name: _floats(batch.column(i)) * scale.get(name, 1.0) for i, name in enumerate(numeric)}
            keep = _inside(columns["t"], window)
            if not keep.all():
                columns = {name: values[keep] for name, values in columns.items()}
            pending.append(columns)
            held += len(columns["t"])
            while held >= rows:
                chunk, pending = _take(pending, rows)
                held -= rows
                yield Log(chunk, str(path))
    except _NotFast:
        strict()   # names the line
        raise LogError(f"{path}: not a readable CSV log") from None
    if held:
        yield Log(_take(pending, held)[0], str(path))


def _take(pending: list[dict[str, np.ndarray]], rows: int) -> tuple[dict[str, np.ndarray], list]:
    """(the first ``rows`` samples of ``pending``, what remains)."""
    names = list(pending[0])
    merged = {name: np.concatenate([p[name] for p in pending]) if len(pending) > 1 else pending[0][name]
              for name in names}
    rest = {name: values[rows:] for name, values in merged.items()}
    return {name: values[:rows] for name, values in merged.items()}, ([rest] if len(rest["t"]) else [])
