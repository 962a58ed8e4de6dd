"""Reading user files with one-line errors, and the one way vsegen writes a file: atomically (a
temporary file next to the target, renamed into place with the mode a plain ``open`` gives), so a
reader never sees a partial file and an interrupted write leaves no debris."""

from __future__ import annotations

import bz2
import difflib
import gzip
import lzma
import os
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

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


@contextmanager
def atomic_path(path: Path) -> Iterator[Path]:
    """A temporary path next to ``path`` (its folder created) for the caller to write; renamed to
    ``path`` when the ``with`` block ends without an error, removed otherwise."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=path.suffix)
    os.close(fd)
    try:
        yield Path(tmp)
        _publish(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_atomic(path: Path, write: Callable[[Path], None]) -> None:
    """``write(temporary_path)``, then the result renamed to ``path`` (see :func:`atomic_path`)."""
    with atomic_path(path) as tmp:
        write(tmp)


def write_text_atomic(path: Path, text: str) -> None:
    """Write ``text`` (UTF-8, newlines as given) to ``path`` atomically."""
    with atomic_path(path) as tmp, open(tmp, "w", newline="", encoding="utf-8") as handle:
        handle.write(text)


def write_folder(files: dict[str, str], folder: Path) -> None:
    """Replace ``folder``'s files by ``files`` ({name: text}, each written atomically); files of
    ``folder`` not in ``files`` are removed."""
    folder.mkdir(parents=True, exist_ok=True)
    for stale in folder.iterdir():
        if stale.is_file() and stale.name not in files:
            stale.unlink()
    for name, text in files.items():
        write_text_atomic(folder / name, text)


def folder_diffs(files: dict[str, str], folder: Path, label: str) -> list[str]:
    """Unified diffs between ``folder`` and ``files`` ({name: text}; empty if identical), files of
    ``folder`` that ``files`` lacks included. ``label`` names the folder in the diff headers."""
    present = {p.name for p in folder.iterdir() if p.is_file()} if folder.is_dir() else set()
    diffs = [file_diff(folder / name, files.get(name), f"{label}/{name}") for name in sorted(set(files) | present)]
    return [diff for diff in diffs if diff]


def file_diff(path: Path, text: str | None, label: str) -> str:
    """The unified diff from ``path``'s content to ``text`` ('' if equal; ``text`` None: the file
    should not exist). ``label`` names the file in the diff headers."""
    old = path.read_text() if path.is_file() else ""
    new = "" if text is None else text
    if old == new:
        return ""
    return "".join(difflib.unified_diff(
        old.splitlines(keepends=True), new.splitlines(keepends=True),
        fromfile=label if path.is_file() else "/dev/null",
        tofile=f"{label} (regenerated)" if text is not None else "/dev/null"))


def _publish(tmp: str, path: Path) -> None:
    """Rename the finished temporary file ``tmp`` to ``path`` with the mode a plain ``open`` would
    have given it (0666 less the umask; mkstemp makes files 0600)."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)
    os.replace(tmp, path)
