"""`vsegen a2l`: fill a generated A2L file's addresses from the linked firmware (ELF).

A generated A2L file (codegen/a2l.py) gives every CHARACTERISTIC and MEASUREMENT a ``SYMBOL_LINK
"symbol" offset`` and address 0. Here each address becomes the symbol's address in the ELF's
symbol table (read with pyelftools) plus the offset, after checking that the object fits in the
symbol (a float A2L against a double build, or a wrong symbol, is refused). The measured state and
outputs link to the kit example's variables by default; ``state``/``output`` name the firmware's own.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from elftools.common.exceptions import ELFError
from elftools.elf.elffile import ELFFile

SIZES = {"FLOAT32_IEEE": 4, "FLOAT64_IEEE": 8, "SLONG": 4, "RL_VALUE_FLOAT32_IEEE": 4, "RL_VALUE_FLOAT64_IEEE": 8}
"""Bytes of each data type (MEASUREMENT) or record layout (CHARACTERISTIC) a generated A2L uses."""
BLOCK = re.compile(r"/begin (CHARACTERISTIC|MEASUREMENT) (\S+) .*?/end \1", re.S)


class A2LError(ValueError):
    """The A2L file or the ELF does not fit (one line: file, object, what was expected)."""


@dataclass(frozen=True)
class Symbol:
    address: int
    size: int


def elf_symbols(path: Path) -> dict[str, Symbol]:
    """The data objects of the ELF ``path``'s symbol table (global and file-local). A name defined
    more than once (file-local objects of two files) is left out, so nothing links to it by chance."""
    try:
        with open(path, "rb") as handle:
            table = ELFFile(handle).get_section_by_name(".symtab")
            if table is None:
                raise A2LError(f"{path}: no symbol table: expected an unstripped ELF (link without -s)")
            seen: dict[str, list[Symbol]] = {}
            for symbol in table.iter_symbols():
                if symbol["st_info"]["type"] == "STT_OBJECT" and symbol.name:
                    seen.setdefault(symbol.name, []).append(Symbol(symbol["st_value"], symbol["st_size"]))
    except OSError as exc:
        raise A2LError(f"{path}: cannot read: {exc.strerror}") from None
    except ELFError as exc:
        raise A2LError(f"{path}: not an ELF file ({exc}): expected the linked firmware") from None
    return {name: found[0] for name, found in seen.items() if len(found) == 1}


def link(text: str, source: str, symbols: dict[str, Symbol], elf: str,
         state: str | None = None, output: str | None = None) -> str:
    """``text`` (the A2L file ``source``) with every address filled from ``symbols`` (of the ELF
    ``elf``); the state's and outputs' MEASUREMENTs relinked to ``state``/``output`` if given."""
    project = re.search(r"/begin PROJECT (\S+)", text)
    if project is None or "SYMBOL_LINK" not in text:
        raise A2LError(f"{source}: no PROJECT with SYMBOL_LINKs: expected an A2L file vsegen generated")
    prefix = project.group(1)
    renames = {f"{prefix}_state.": state, f"{prefix}_output.": output}

    def fill(block: re.Match) -> str:
        body, kind, name = block.group(0), block.group(1), block.group(2)
        linked = re.search(r'SYMBOL_LINK "(\S+)" (\d+)', body)
        if linked is None:
            raise A2LError(f"{source}: {kind} {name}: no SYMBOL_LINK: expected one in every object")
        symbol, offset = linked.group(1), int(linked.group(2))
        for start, new in renames.items():
            if new and name.startswith(start):
                symbol = new
        if symbol not in symbols:
            hint = " (--state / --output name the firmware's variables)" if name.startswith(tuple(renames)) else \
                (" (the linker dropped it: link the kit's <name>_calibration.c and keep the object, e.g. KEEP() in "
                 "the linker script; a kit older than its volatile calibration is folded by -flto: regenerate it)"
                 if kind == "CHARACTERISTIC" else "")
            raise A2LError(f"{elf}: no data object '{symbol}' for {kind} {name}: expected it in the symbol "
                           f"table, defined once{hint}")
        count = re.search(r"MATRIX_DIM (\d+)", body)
        type_name = re.search(r"\b(FLOAT32_IEEE|FLOAT64_IEEE|SLONG|RL_VALUE_FLOAT\d\d_IEEE)\b", body).group(1)
        end = offset + SIZES[type_name] * (int(count.group(1)) if count else 1)
        if end > symbols[symbol].size:
            raise A2LError(f"{elf}: {kind} {name} needs bytes {offset}..{end} of '{symbol}', which has "
                           f"{symbols[symbol].size}: expected the build this A2L file was generated with")
        body = re.sub(r"0x[0-9A-Fa-f]{8}", f"0x{symbols[symbol].address + offset:08X}", body, count=1)
        return re.sub(r'SYMBOL_LINK "\S+"', f'SYMBOL_LINK "{symbol}"', body, count=1)

    return BLOCK.sub(fill, text)
