"""Raw CAN logs decoded with the car's DBC: bus-logging MDF4 (CAN frames, as Vector and CANedge
loggers record them; decoded by asammdf's bus-logging extraction) and Vector BLF and ASC (read
by python-can, decoded by cantools). Each log column comes from a DBC signal named by the channel
map (``channel`` = the signal, ``message`` = its message where the name repeats; without a map, the
signal named like the column); the signals then go onto the estimator's grid like MDF4 channels
(:mod:`~vsegen.harness.logs.grid`). A decoded log is held in memory, one float array per signal.

Mistakes are one line: a DBC that does not parse, a column whose signal the DBC lacks, a signal
whose message never appears in the log, a DBC unit the channel map contradicts.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vsegen.harness.logs.channels import ChannelMap, Column, file_unit_conflict
from vsegen.harness.logs.grid import SeriesChannel, grid_source
from vsegen.harness.logs.mdf import SUFFIXES, open_mdf
from vsegen.harness.logs.stream import LogSource
from vsegen.harness.logs.table import OPTIONAL_INPUTS, REQUIRED, TRUTH, LogError

FRAME_SUFFIXES = (".blf", ".asc")
"""Vector's binary and text CAN logs; a raw-CAN MDF4 keeps the MDF4 suffixes (read with a DBC)."""


def load_dbc(path: Path):
    """The cantools database of the DBC file ``path``; LogError (one line) when it cannot be read."""
    import cantools

    if not Path(path).is_file():
        raise LogError(f"{path}: cannot read DBC file: no such file")
    try:
        return cantools.database.load_file(str(path), database_format="dbc", strict=False)
    except Exception as exc:  # cantools raises parser errors of several kinds
        reason = str(exc).splitlines()[0][:120] if str(exc) else type(exc).__name__
        raise LogError(f"{path}: not a readable DBC file: {reason}") from None


def open_can_log(path: Path, dbc: Path, channels: ChannelMap, sample_time: float,
                 window: tuple[float | None, float | None] = (None, None)) -> LogSource:
    """The log columns of a raw CAN log (BLF, ASC or bus-logging MDF4) decoded with ``dbc`` and
    brought onto a uniform grid of ``sample_time`` s, cut to ``window`` (s)."""
    database = load_dbc(dbc)
    located = _locate(database, dbc, channels)
    if Path(path).suffix.lower() in SUFFIXES:
        series = _mdf_signals(path, dbc, located)
    else:
        series = _frame_signals(path, database, located)
    silent = [f"'{signal.name}' (message {message.name}, 0x{message.frame_id:X}) for column '{name}'"
              for name, (message, signal, _) in located.items() if name in REQUIRED and name not in series]
    if silent:
        raise LogError(f"{path}: signal{'s' if len(silent) > 1 else ''} {', '.join(silent)} never received: expected "
                       f"frames of {'them' if len(silent) > 1 else 'it'} in the log (DBC {dbc})")
    found = {name: SeriesChannel(t, values, located[name][2].scale) for name, (t, values) in series.items()}
    return grid_source(str(path), found, sample_time, window, "CAN signals")


def _locate(database, dbc: Path, channels: ChannelMap) -> dict[str, tuple[object, object, Column]]:
    """column -> (DBC message, DBC signal, channel map entry) of every column the DBC carries;
    LogError when a required column's signal is not in the DBC, is in several messages without
    the map's ``message``, or has a unit the map contradicts."""
    located, missing = {}, []
    for name in (*REQUIRED[1:], *OPTIONAL_INPUTS, *TRUTH):
        column = channels.column(name)
        carriers = [(message, signal) for message in database.messages for signal in message.signals
                    if signal.name == column.channel and column.message in (None, message.name)]
        if not carriers:
            if name in REQUIRED:
                missing.append(f"'{column.channel}'" + (f" in message {column.message}" if column.message else "")
                               + f" for column '{name}'")
            continue
        if len(carriers) > 1:
            raise LogError(f"{dbc}: signal '{column.channel}' for column '{name}' is in messages "
                           f"{', '.join(m.name for m, _ in carriers)}: expected the channel map to choose one with "
                           f"message = NAME ({channels.source})")
        message, signal = carriers[0]
        written = file_unit_conflict(column, str(signal.unit or ""))
        if written:
            raise LogError(f"{dbc}: signal '{signal.name}' is in {written} (the DBC's unit), the channel map reads it "
                           f"as {column.unit}: expected unit = \"{written}\" in [columns.{name}] of {channels.source}")
        located[name] = (message, signal, column)
    if missing:
        raise LogError(f"{dbc}: no signal {', '.join(missing)}: expected {'them' if len(missing) > 1 else 'it'} in a "
                       f"message of the DBC ({len(database.messages)} messages), or the channel map "
                       f"({channels.source}) to name the DBC's signals")
    return located


def _frame_signals(path: Path, database, located) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """column -> (time stamps in s from the log's first frame, physical values) of the BLF or ASC
    log ``path``, decoded with cantools."""
    import can

    wanted: dict[int, list[tuple[str, str]]] = {}
    for name, (message, signal, _) in located.items():
        wanted.setdefault(message.frame_id, []).append((name, signal.name))
    messages = {frame_id: database.get_message_by_frame_id(frame_id) for frame_id in wanted}
    times: dict[str, list[float]] = {name: [] for name in located}
    values: dict[str, list[float]] = {name: [] for name in located}
    first = None
    reader_type = can.BLFReader if Path(path).suffix.lower() == ".blf" else can.ASCReader
    try:
        for frame in reader_type(str(path)):
            first = frame.timestamp if first is None else first
            if frame.is_error_frame or frame.is_remote_frame or frame.arbitration_id not in wanted:
                continue
            decoded = messages[frame.arbitration_id].decode(bytes(frame.data), decode_choices=False,
                                                            allow_truncated=True)
            for name, signal in wanted[frame.arbitration_id]:
                if signal in decoded:
                    times[name].append(frame.timestamp - first)
                    values[name].append(float(decoded[signal]))
    except FileNotFoundError:
        raise LogError(f"{path}: cannot read CAN log: no such file") from None
    except Exception as exc:  # python-can and cantools raise many types for a damaged file
        reason = str(exc).splitlines()[0][:120] if str(exc) else type(exc).__name__
        raise LogError(f"{path}: not a readable {Path(path).suffix[1:].upper()} CAN log: {reason}") from None
    return {name: (np.array(times[name]), np.array(values[name])) for name in located if times[name]}


def holds_can_frames(path: Path) -> bool:
    """Whether the MDF4 file ``path`` is a bus logging of CAN frames (LogError if unreadable)."""
    mdf = open_mdf(path)
    try:
        return "CAN_DataFrame" in mdf.channels_db
    finally:
        mdf.close()


def _mdf_signals(path: Path, dbc: Path, located) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """column -> (time stamps in s, physical values) of a bus-logging MDF4 file, decoded by
    asammdf's bus-logging extraction."""
    mdf = open_mdf(path)
    try:
        if "CAN_DataFrame" not in mdf.channels_db:
            raise LogError(f"{path}: no CAN frames (channel CAN_DataFrame): expected a bus-logging MDF4 file to "
                           f"decode with --dbc {dbc}")
        decoded = mdf.extract_bus_logging(database_files={"CAN": [(str(dbc), 0)]})
    finally:
        mdf.close()
    series = {}
    try:
        for name, (message, signal, _) in located.items():
            channel = f"{message.name}.{signal.name}"
            if channel in decoded.channels_db:
                data = decoded.get(channel, *decoded.channels_db[channel][0])
                series[name] = (np.array(data.timestamps, dtype=float), np.array(data.samples, dtype=float))
    finally:
        decoded.close()
    return series
