"""Loading vehicle files from disk (the I/O half of model.params)."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from vsegen.harness.project.files import read_user_text
from vsegen.model.params import ParameterError, VehicleConfig, parse_vehicle


def load_vehicle(path: Path | str) -> VehicleConfig:
    """Read and validate a vehicle TOML file; ParameterError (one line) on any problem."""
    path = Path(path)
    text = read_user_text(path, ParameterError, "vehicle file (TOML)")
    return parse_vehicle(text, str(path), path.stem)


def with_settings(text: str, section: str, comments: dict[str, str] | None = None,
                  **values: float | int | str | list[float]) -> str:
    """``text`` of a vehicle file with ``key = value`` set in table ``[section]`` (e.g.
    "estimator.switching", "vehicle"). Each key must already be in that table; its trailing comment
    is kept, or replaced by ``comments[key]`` where given. Strings are written quoted, lists as
    arrays."""
    lines, current, found = text.split("\n"), None, set()
    for i, line in enumerate(lines):
        header = re.match(r"\s*\[([^\]]+)\]\s*(#.*)?$", line)
        if header:
            current = header.group(1).strip()
            continue
        match = re.match(r"(\s*)([A-Za-z_][A-Za-z0-9_]*)(\s*=\s*)([^#]*?)(\s*#.*)?$", line)
        if current == section and match and match.group(2) in values:
            value = values[match.group(2)]
            if isinstance(value, str):
                rendered = f'"{value}"'
            elif isinstance(value, (list, tuple)):
                rendered = "[" + ", ".join(repr(float(v)) for v in value) + "]"
            elif isinstance(value, int) and not isinstance(value, bool):
                rendered = repr(value)  # a count or a seed stays a whole number
            else:
                rendered = repr(float(value))
            comment = f"  # {comments[match.group(2)]}" if comments and match.group(2) in comments \
                else match.group(5) or ""
            lines[i] = f"{match.group(1)}{match.group(2)}{match.group(3)}{rendered}{comment}"
            found.add(match.group(2))
    missing = set(values) - found
    if missing:
        raise KeyError(f"[{section}] has no key {', '.join(sorted(missing))}")
    return "\n".join(lines)


def with_form(text: str, estimator: str, real: str, params: str) -> str:
    """``text`` of a vehicle file with the form "<estimator>:<real>-<params>" added to [codegen]
    ``forms`` (the key, or the table, added where missing); the rest of the file as it was."""
    entry = f"{estimator}:{real}-{params}"
    data = tomllib.loads(text)
    forms = list(data.get("codegen", {}).get("forms", []))
    if entry in forms:
        return text
    rendered = "forms = [" + ", ".join(f'"{form}"' for form in [*forms, entry]) + "]"
    lines = text.split("\n")
    table = next((i for i, line in enumerate(lines) if re.match(r"\s*\[codegen\]\s*(#.*)?$", line)), None)
    if table is None:
        return text.rstrip("\n") + f"\n\n[codegen]\n{rendered}\n"
    end = next((i for i in range(table + 1, len(lines)) if re.match(r"\s*\[", lines[i])), len(lines))
    start = next((i for i in range(table + 1, end) if re.match(r"\s*forms\s*=", lines[i])), None)
    if start is None:
        last_key = max((i for i in range(table + 1, end) if re.match(r"\s*[A-Za-z_]", lines[i])), default=table)
        return "\n".join([*lines[:last_key + 1], rendered, *lines[last_key + 1:]])
    stop = start
    while "]" not in lines[stop].split("#")[0]:
        stop += 1
    return "\n".join([*lines[:start], rendered, *lines[stop + 1:]])
