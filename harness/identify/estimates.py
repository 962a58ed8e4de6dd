"""Estimates of a car's parameters from ordinary driving logs, each with a 95 % interval.

Every function takes the logs and returns an :class:`Estimate` per parameter it could support or a
:class:`Refusal` saying why not. Intervals come from least squares with the residuals' serial
correlation accounted for (the sample count is reduced to the effective one, Bartlett's formula),
so thousands of correlated samples do not claim more than they hold. Units SI, signs as in
docs/conventions.md.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from vsegen.harness.logs.table import Log, runs
from vsegen.harness.physics import segments
from vsegen.model.bicycle import GRAVITY

Z95 = 1.96
BLOCK = 0.5
"""s, length of the blocks whose means the steady-state regressions use."""


@dataclass(frozen=True)
class Estimate:
    """An identified value with its 95 % interval and where it came from."""

    name: str
    value: float
    low: float
    high: float
    unit: str
    support: str

    @property
    def significant(self) -> bool:
        """The 95 % interval excludes 0."""
        return self.low > 0.0 or self.high < 0.0

    def describe(self, digits: int = 4) -> str:
        return (f"{self.value:.{digits}g} {self.unit} (95 % {self.low:.{digits}g}..{self.high:.{digits}g}) "
                f"from {self.support}")


@dataclass(frozen=True)
class Refusal:
    """A parameter the logs cannot support, and why."""

    name: str
    why: str


@dataclass(frozen=True)
class Selection:
    """Samples selected from the logs: per log, its mask."""

    logs: Sequence[Log]
    masks: Sequence[np.ndarray]

    @property
    def seconds(self) -> float:
        return float(sum(m.sum() * log.sample_time for log, m in zip(self.logs, self.masks)))

    @property
    def support(self) -> str:
        used = [(log, m) for log, m in zip(self.logs, self.masks) if m.any()]
        pieces = sum(len(runs(m)) for _, m in used)
        names = ", ".join(_name(log) for log, _ in used)
        return f"{self.seconds:.1f} s in {pieces} segment(s) of {names}"

    def column(self, signal: str | Callable[[Log], np.ndarray]) -> np.ndarray:
        """The selected samples of a column (or of ``signal(log)``), logs concatenated."""
        return np.concatenate([_values(log, signal)[mask] for log, mask in zip(self.logs, self.masks)])

    def block_means(self, signal: str | Callable[[Log], np.ndarray], seconds: float = BLOCK) -> np.ndarray:
        """Means over consecutive blocks of ``seconds`` inside each selected run (a partial block at
        a run's end is dropped). Regressions on block means keep sensor noise out of the
        regressors (no attenuation bias) while the blocks stay short against the manoeuvres."""
        means = []
        for log, mask in zip(self.logs, self.masks):
            values, n = _values(log, signal), max(1, int(round(seconds / log.sample_time)))
            for run in runs(mask):
                chunk = values[run]
                count = len(chunk) // n
                means.extend(chunk[:count * n].reshape(count, n).mean(axis=1))
        return np.asarray(means)


def _values(log: Log, signal: str | Callable[[Log], np.ndarray]) -> np.ndarray:
    return log[signal] if isinstance(signal, str) else signal(log)


def _name(log: Log) -> str:
    return str(log.source).rsplit("/", 1)[-1]


def select(logs: Sequence[Log], selector: Callable[[Log], np.ndarray]) -> Selection:
    return Selection(logs, [selector(log) for log in logs])


def effective_fraction(residuals: np.ndarray, max_lag: int = 200) -> float:
    """N_eff / N of serially correlated residuals, 1 / (1 + 2 sum rho_k) over the lags until the
    autocorrelation first drops below zero (Bartlett); at most 1."""
    r = residuals - residuals.mean()
    denominator = float(r @ r)
    if denominator == 0.0 or len(r) < 3:
        return 1.0
    total = 0.0
    for lag in range(1, min(max_lag, len(r) - 1)):
        rho = float(r[:-lag] @ r[lag:]) / denominator
        if rho <= 0.0:
            break
        total += rho
    return 1.0 / (1.0 + 2.0 * total)


def fit(residual: Callable[[np.ndarray], np.ndarray], start: np.ndarray,
        scale: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(parameters, their covariance) minimising ||residual||^2, the covariance inflated by the
    residuals' serial correlation (N / N_eff)."""
    result = least_squares(residual, start, x_scale=scale if scale is not None else 1.0, method="lm")
    return result.x, _covariance(result.fun, result.jac, len(start))


JACKKNIFE_BLOCKS = 20
"""At most this many blocks of neighbouring groups are left out in turn by :func:`fit_with_jackknife`."""


def fit_with_jackknife(residual: Callable[[np.ndarray], np.ndarray], start: np.ndarray,
                       groups: np.ndarray, bounds=(-np.inf, np.inf)) -> tuple[np.ndarray, np.ndarray]:
    """(parameters, covariance) as :func:`fit`, each variance raised to the delete-a-block jackknife's
    where that is larger: the spread between parts of the data (``groups``: an integer per residual,
    neighbouring groups merged into at most JACKKNIFE_BLOCKS blocks) also covers model error, which
    the residual noise alone does not show. Each left-out fit is one Gauss-Newton step from the
    whole fit, p + (J'J - J_b'J_b)^-1 J_b' r_b, not a new optimisation. ``bounds`` as scipy's
    ``least_squares`` takes them."""
    result = least_squares(residual, start, bounds=bounds, method="trf")
    res, jac = result.fun, result.jac
    covariance = _covariance(res, jac, len(start))
    labels = np.unique(groups)
    count = min(JACKKNIFE_BLOCKS, len(labels))
    if count < 3:
        return result.x, covariance
    block = np.searchsorted(labels, groups) * count // len(labels)
    normal = jac.T @ jac
    left_out = np.array([result.x + np.linalg.lstsq(normal - jac[block == b].T @ jac[block == b],
                                                    jac[block == b].T @ res[block == b], rcond=None)[0]
                         for b in range(count)])
    jackknife = (count - 1) / count * ((left_out - left_out.mean(axis=0)) ** 2).sum(axis=0)
    return result.x, np.diag(np.maximum(np.diag(covariance), jackknife))


def _covariance(res: np.ndarray, jac: np.ndarray, parameters: int) -> np.ndarray:
    """The least-squares covariance, inflated by the residuals' serial correlation (N / N_eff)."""
    sigma2 = float(res @ res) / max(len(res) - parameters, 1)
    return sigma2 * np.linalg.pinv(jac.T @ jac) / effective_fraction(res)


def interval(name: str, value: float, sd: float, unit: str, support: str) -> Estimate:
    return Estimate(name, float(value), float(value - Z95 * sd), float(value + Z95 * sd), unit, support)


def sensor_offsets_and_noise(logs: Sequence[Log]) -> list[Estimate | Refusal]:
    """Gyro and accelerometer offsets and white-noise levels from straight driving.

    Offsets: mean yaw rate and a_y while driving straight (both 0 on a level road), and mean
    a_x - dv_x/dt. Noise: from second differences, var(x_k - 2 x_k-1 + x_k-2) = 6 sigma^2 for white
    noise on a signal that is smooth at the sample rate.
    """
    straight = select(logs, segments.straight)
    names = ("gyro_offset", "ay_offset", "ax_offset", "gyro_noise", "ay_noise", "ax_noise")
    if straight.seconds < 2.0:
        why = f"no straight driving above {segments.MIN_SPEED:g} m/s for 2 s (found {straight.seconds:.1f} s)"
        return [Refusal(name, why) for name in names]
    out: list[Estimate | Refusal] = []

    def dvx(log: Log, vx: np.ndarray) -> np.ndarray:
        return segments.derivative(np.nan_to_num(vx), log.sample_time, int(round(1.0 / log.sample_time)))

    ax_free = straight.column(lambda log: log["ax"] - dvx(log, log["vx"]))
    for name, values, unit in (("gyro_offset", straight.column("r"), "rad/s"),
                               ("ay_offset", straight.column("ay"), "m/s^2"),
                               ("ax_offset", ax_free, "m/s^2")):
        sd = values.std() / np.sqrt(len(values) * effective_fraction(values))
        out.append(interval(name, values.mean(), sd, unit, straight.support))
    for name, column, unit in (("gyro_noise", "r", "rad/s"), ("ay_noise", "ay", "m/s^2"),
                               ("ax_noise", "ax", "m/s^2")):
        second = np.concatenate([np.diff(log[column][run], 2)
                                 for log, mask in zip(logs, straight.masks) for run in runs(mask)])
        sigma = float(np.sqrt(np.mean(second**2) / 6.0))
        sd = sigma / np.sqrt(2.0 * len(second) / 3.0)  # neighbouring second differences overlap
        out.append(interval(name, sigma, sd, unit, straight.support))
    return out


def roll_gradient(logs: Sequence[Log], gyro_offset: float, ay_offset: float) -> Estimate | Refusal:
    """k in phi = k a_y (rad/(m/s^2)) from quasi-steady cornering, where the true a_y = r v_x:
    the body-fixed sensor reads a_y,m = a_y cos(k a_y) + g sin(k a_y) + offset (the offset from
    straight driving)."""
    steady = select(logs, segments.steady_cornering)
    if steady.seconds < 1.0:
        return Refusal("roll_gradient", f"no quasi-steady cornering above {segments.CORNERING:g} m/s^2 "
                                        f"(found {steady.seconds:.1f} s)")
    ay_true = steady.block_means(lambda log: (log["r"] - gyro_offset) * log["vx"])
    ay_measured = steady.block_means("ay") - ay_offset

    def residual(p: np.ndarray) -> np.ndarray:
        phi = p[0] * ay_true
        return ay_true * np.cos(phi) + GRAVITY * np.sin(phi) - ay_measured

    (k,), cov = fit(residual, np.array([0.01]), np.array([0.01]))
    return interval("roll_gradient", k, np.sqrt(cov[0, 0]), "rad/(m/s^2)", steady.support)


def stability_factor(logs: Sequence[Log], wheelbase: float, gyro_offset: float) -> Estimate | Refusal:
    """K_s (s^2/m^2, > 0 understeer) from quasi-steady cornering in the linear range:
    delta = l r / v_x + l K_s r v_x (the steer angle sensor assumed without offset)."""
    steady = select(logs, lambda log: segments.steady_cornering(log, 0.5, segments.LINEAR_LATERAL))
    if steady.seconds < 1.0:
        return Refusal("stability_factor", f"no quasi-steady cornering between 0.5 and "
                                           f"{segments.LINEAR_LATERAL:g} m/s^2 (found {steady.seconds:.1f} s)")
    r_vx = steady.block_means(lambda log: (log["r"] - gyro_offset) * log["vx"])
    y = steady.block_means(lambda log: log["delta"] - wheelbase * (log["r"] - gyro_offset) / log["vx"])

    def residual(p: np.ndarray) -> np.ndarray:
        return wheelbase * p[0] * r_vx - y

    (ks,), cov = fit(residual, np.array([1e-4]), np.array([1e-4]))
    return interval("stability_factor", ks, np.sqrt(cov[0, 0]), "s^2/m^2", steady.support)
