"""One row of a campaign's table: what one estimator with one settings file did over one log,
summed chunk by chunk (memory does not grow with the log).

Columns (units in the names): the log's duration, distance, speed and |a_y| coverage (seconds per
band), the time each status bit was raised and the time flagged at all, the sideslip scores and the
longest silent stretch where the log has a reference (``beta_ref``; NaN otherwise), and the input
faults the estimator's monitors found (status bits of a faulty input, with the time each was
first raised).
"""

from __future__ import annotations

import math

import numpy as np

from vsegen.harness.logs.table import Log
from vsegen.harness.score.metrics import ScoreSums, SilentStretch
from vsegen.model import status

SPEED_BANDS_KMH = (0.0, 30.0, 60.0, 100.0, 130.0, math.inf)
"""km/h: the speed coverage bands, seconds in each."""
LATERAL_BANDS = (0.0, 2.0, 4.0, 6.0, math.inf)
"""m/s^2: the |a_y| coverage bands, seconds in each."""
INPUT_FAULTS = (status.INVALID_INPUT, status.INPUT_FROZEN, status.LATERAL_INCONSISTENT, status.STEERING_OFFSET,
                status.YAW_RATE_MISMATCH)
"""Status bits that say an input is faulty (rather than the estimate being uncertain)."""


def band_names(prefix: str, edges: tuple[float, ...], unit: str) -> list[str]:
    return [f"{prefix}_{a:g}_{'up' if math.isinf(b) else f'{b:g}'}_{unit}_s" for a, b in zip(edges, edges[1:])]


SPEED_COLUMNS = band_names("time_speed", SPEED_BANDS_KMH, "kmh")
LATERAL_COLUMNS = band_names("time_ay", LATERAL_BANDS, "ms2")
STATUS_COLUMNS = [f"time_{bit.name}_s" for bit in status.BITS]


class RowSums:
    """The row of one (log, estimator, settings), fed one chunk of the log and of the estimates at
    a time (:meth:`add`), read at the end (:meth:`row`)."""

    def __init__(self, sample_time: float):
        self.T = sample_time
        self.samples = 0
        self.distance = 0.0
        self.speed = np.zeros(len(SPEED_COLUMNS))
        self.lateral = np.zeros(len(LATERAL_COLUMNS))
        self.bits = np.zeros(len(status.BITS))
        self.flagged = 0
        self.first_fault: dict[str, float] = {}
        self.scores = ScoreSums("<log>", "<estimates>")
        self.silent = SilentStretch(sample_time)
        self.referenced = False

    def add(self, log: Log, estimates: Log) -> None:
        """The next chunk of the log (its ``t``, inputs and any truth) and of the estimates."""
        self.samples += len(log)
        vx = np.nan_to_num(np.asarray(log["vx"], dtype=float))
        self.distance += float(np.abs(vx).sum()) * self.T
        self.speed += np.histogram(np.abs(vx) * 3.6, SPEED_BANDS_KMH)[0] * self.T
        self.lateral += np.histogram(np.abs(np.nan_to_num(log["ay"])), LATERAL_BANDS)[0] * self.T
        code = np.asarray(estimates["status"], dtype=np.int64)
        self.flagged += int(np.count_nonzero(code))
        for i, bit in enumerate(status.BITS):
            raised = (code & bit.value) != 0
            self.bits[i] += int(raised.sum())
            if bit.value in INPUT_FAULTS and bit.name not in self.first_fault and raised.any():
                self.first_fault[bit.name] = float(log["t"][np.argmax(raised)])
        if "beta_ref" in log:
            self.referenced = True
            self.scores.add(log, Log({"t": estimates["t"], "beta": estimates["beta"]}))
            self.silent.add(log["t"], estimates["beta"] - log["beta_ref"], code, log["beta_ref"])

    def row(self) -> dict:
        """The row's columns (see the module docstring)."""
        beta = next((score for score in self.scores.result() if score.signal == "beta"), None)
        return {
            "samples": self.samples,
            "duration_s": self.samples * self.T,
            "distance_km": self.distance / 1000.0,
            **dict(zip(SPEED_COLUMNS, self.speed.tolist())),
            **dict(zip(LATERAL_COLUMNS, self.lateral.tolist())),
            "time_flagged_s": self.flagged * self.T,
            **dict(zip(STATUS_COLUMNS, (self.bits * self.T).tolist())),
            "beta_rmse_deg": beta.rmse if beta else math.nan,
            "beta_mean_deg": beta.mean if beta else math.nan,
            "beta_max_deg": beta.max if beta else math.nan,
            "silent_longest_s": self.silent.longest if self.referenced else math.nan,
            "silent_longest_at_s": self.silent.start,
            "input_faults": "; ".join(f"{name} at {t:.2f} s" for name, t in sorted(self.first_fault.items(),
                                                                                  key=lambda item: item[1])),
        }
