"""Convert the Revs lap of MBDS/sideslip-angle-vehicle-estimation into vsegen's log format.

Source: the folder ``datasets/20140222_01_01_03_250lm`` of that repository (MIT licence, see
LICENSE beside this file): one text file per signal, one value per line, 100 Hz, already cut to the
driven part of the lap (samples 15000..70000 of the original recording) and in SI units except the
filtered channels, which are not used. The log written here has the columns of docs/conventions.md:

=========  ==================  ======  =====================================================
column     source file         unit    meaning
=========  ==================  ======  =====================================================
t          t.txt               s       time of the OxTS INS
delta      delta.txt           rad     road-wheel angle (the car's steering sensor, 1 kHz decimated to 100 Hz)
vx         vx.txt              m/s     longitudinal speed at the CG (INS): the estimators' v_x input
ax, ay     axCG.txt, ayCG.txt  m/s^2   accelerations at the CG (INS, body frame)
r          yawRate.txt         rad/s   yaw rate (INS)
vx_ref     vx.txt              m/s     reference longitudinal speed (the same INS channel)
vy_ref     vy.txt              m/s     reference lateral speed at the CG (INS)
beta_ref   beta_true.txt       rad     reference sideslip angle at the CG (INS)
=========  ==================  ======  =====================================================

Values are copied as the source prints them (8 significant digits), so the conversion is lossless.

Use: ``python data/real/revs_250lm/convert.py SOURCE_FOLDER OUT.csv.gz``
"""

from __future__ import annotations

import gzip
import hashlib
import sys
from pathlib import Path

COLUMNS = {
    "t": "t.txt", "delta": "delta.txt", "vx": "vx.txt", "ax": "axCG.txt", "ay": "ayCG.txt",
    "r": "yawRate.txt", "vx_ref": "vx.txt", "vy_ref": "vy.txt", "beta_ref": "beta_true.txt",
}
"""Log column -> source file."""


def read_column(path: Path) -> list[str]:
    """The values of one source file as text, each re-printed with 8 significant digits."""
    try:
        lines = path.read_text().split()
    except OSError as exc:
        raise SystemExit(f"{path}: cannot read ({exc.strerror}); expected the dataset folder's {path.name}") from None
    values = []
    for number, cell in enumerate(lines, start=1):
        try:
            values.append(f"{float(cell):.8g}")
        except ValueError:
            raise SystemExit(f"{path}:{number}: '{cell}' is not a number") from None
    return values


def convert(source: Path) -> str:
    """The log's CSV text from the dataset folder ``source``."""
    columns = {name: read_column(source / file) for name, file in COLUMNS.items()}
    lengths = {len(values) for values in columns.values()}
    if len(lengths) != 1:
        counts = ", ".join(f"{COLUMNS[n]} {len(v)}" for n, v in columns.items())
        raise SystemExit(f"{source}: the signal files differ in length ({counts}); "
                         "expected one value per sample in each")
    rows = [",".join(columns)] + [",".join(row) for row in zip(*columns.values())]
    return "\n".join(rows) + "\n"


def main(argv: list[str]) -> None:
    if len(argv) != 2:
        raise SystemExit("usage: python convert.py SOURCE_FOLDER OUT.csv.gz")
    source, out = Path(argv[0]), Path(argv[1])
    text = convert(source)
    # mtime 0: the same source gives the same bytes
    with gzip.GzipFile(out, "wb", mtime=0) as stream:
        stream.write(text.encode())
    digest = hashlib.sha256(text.encode()).hexdigest()
    print(f"wrote {out}: {text.count(chr(10)) - 1} samples, SHA-256 of the CSV text {digest}")


if __name__ == "__main__":
    main(sys.argv[1:])
