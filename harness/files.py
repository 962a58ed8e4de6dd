"""Reading user files with one-line errors, and writing files atomically."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path


def read_user_text(path: Path, error: type[Exception], what: str) -> str:
    """The UTF-8 text of ``path``; ``error`` with one line (file, reason, expectation) otherwise."""
    try:
        raw = Path(path).read_bytes()
    except OSError as exc:
        raise error(f"{path}: cannot read {what}: {exc.strerror}") from None
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
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
