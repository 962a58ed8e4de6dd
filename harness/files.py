"""Reading user files with one-line errors, and writing files atomically."""

from __future__ import annotations

import bz2
import gzip
import lzma
import os
import tempfile
from pathlib import Path

from vsegen.codegen.generate import publish

DECOMPRESSORS = {".gz": gzip.decompress, ".bz2": bz2.decompress, ".xz": lzma.decompress}
"""Compressed files are read by their suffix (e.g. drive.csv.gz)."""


def read_user_text(path: Path, error: type[Exception], what: str) -> str:
    """The UTF-8 text of ``path`` (decompressed when it ends in .gz, .bz2 or .xz); ``error`` with
    one line (file, reason, expectation) otherwise."""
    try:
        raw = Path(path).read_bytes()
    except OSError as exc:
        raise error(f"{path}: cannot read {what}: {exc.strerror}") from None
    opener = DECOMPRESSORS.get(Path(path).suffix.lower())
    if opener is not None:
        try:
            raw = opener(raw)
        except (OSError, EOFError, ValueError, lzma.LZMAError) as exc:
            raise error(f"{path}: cannot decompress {what} ({Path(path).suffix}): {exc}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = "\x00"
    if "\x00" in text:
        raise error(f"{path}:1: not a text file: expected a {what} in UTF-8")
    return text


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` to a temporary file next to ``path`` and rename it into place, so a reader
    never sees a partial file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    try:
        with os.fdopen(fd, "w", newline="") as handle:
            handle.write(text)
        publish(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
