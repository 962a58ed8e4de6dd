"""ISO 3888-1 double-lane-change course (shared/methods/README.md, "DLC geometry").

Sections 15 / 30 / 25 / 25 / 15 / 15 m: entry lane, lane change, offset lane, change back, exit
lane, run-out; lateral offset 3.5 m. The driver's target path is the centre line, with
half-cosine transitions over the two change sections. x measured from the course entry (m).
"""

from __future__ import annotations

import numpy as np

SECTIONS = (15.0, 30.0, 25.0, 25.0, 15.0, 15.0)
OFFSET = 3.5
LENGTH = sum(SECTIONS)


def centre_line(x: np.ndarray | float) -> np.ndarray:
    """Lateral position y (m, positive left) of the course centre line at distance x (m)."""
    x = np.asarray(x, dtype=float)
    s1, s2, s3, s4 = np.cumsum(SECTIONS[:4])
    up = np.clip((x - s1) / (s2 - s1), 0.0, 1.0)
    down = np.clip((x - s3) / (s4 - s3), 0.0, 1.0)
    return OFFSET * 0.5 * ((1 - np.cos(np.pi * up)) - (1 - np.cos(np.pi * down)))
