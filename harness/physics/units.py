"""Unit sanity from the redundancy of a chassis log: wrong units that pass the range checks.

Every relation below holds in any manoeuvre, not only in steady cornering, so a log is judged
wherever the car moves enough:

* **v_x against the wheel speeds**: v_x is the free axle's rolling speed, R_eff mean(|omega|)
  (the non-driven axle when the vehicle file's [plant] names the driven one; else, at each sample,
  the axle rolling nearest v_x: a driven axle's wheels spin up on a slippery road);
* **r against an axle's wheel speed difference**: r = R_eff (omega_right - omega_left) / t_w (the
  non-driven axle; else, at each sample, the axle whose difference is nearest r: an unloaded
  inner wheel of the driven axle spins up in a long corner, while a wrong unit or sign is far
  from both);
* **a_y against r v_x**: a_y = v_y' + r v_x, and v_y' is small beside r v_x in most samples (the
  body's roll adds g k a_y, a few tens of percent);
* **delta against the yaw rate through the bicycle model**: the linear 2-DOF model driven by the
  logged delta at the logged speed predicts r, with the lag of a transient, in the tyres' linear
  range (a wider band where a log never leaves the nonlinear range).

Each relation gives the median ratio of the logged signal to its prediction over the samples
where both are large enough. A ratio far from 1, with few samples agreeing (a unit is wrong
everywhere, a spin only from where it starts), is one line naming the column and the likely
cause (v_x in km/h or mph, r in deg/s, a_y in g, delta in degrees or as the steering-wheel
angle), exit 2. A column no relation could judge (no wheel speeds, too little motion) is listed
by :func:`check_units`, so the caller can say that its unit was not checked.

A signal that repeats one value bit for bit (a frozen sensor or CAN signal) is judged on the rest
of the log, and said in a note; so is a yaw rate whose ratio to the wheels', inside the band, is
far from 1 (a scaling error of the yaw rate, e.g. a factor typed wrong in a DBC).
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from vsegen.harness.logs.table import Log, LogError
from vsegen.harness.physics import segments

SMOOTHING = 0.3
"""s: every signal is averaged over this before its ratios are taken (noise down about fivefold)."""
MIN_SAMPLES = 100
"""Samples a relation needs before it judges (about a second at 100 Hz)."""
MIN_SPEED = 5.0
"""m/s: slower samples are not judged (the wheel and yaw relations need motion)."""
SPEED_RATIO = (0.8, 1.25)
"""v_x / (R_eff mean |omega|) of the free axle: tyre radius spread, slip."""
YAW_RATIO = (0.6, 1.6)
"""r / (R_eff (omega_right - omega_left) / t_w): steer angle, slip and track spread."""
LATERAL_RATIO = (0.5, 1.8)
"""a_y / (r v_x) in any manoeuvre: roll adds up to ~30 %, transients, lag and a sliding car the
rest (a mph speed, the nearest mistake, gives 0.45)."""
STEER_RATIO = (0.25, 4.0)
"""r / r_model of the bicycle model driven by delta, in the linear range (|a_y| < 4 m/s^2): wide,
for a vehicle file whose stiffnesses are rough (the steering-wheel angle, the nearest mistake,
gives 1/15)."""
SATURATED_STEER_RATIO = (0.15, 4.0)
"""The same where |a_y| exceeds the linear range: saturated tyres yaw less (or, oversteering, more);
judged on the samples where r turns the way the model does (a sliding car counter-steers)."""
AGREEING = 0.25
"""A relation refuses only when fewer than this share of its samples agree with it: a unit is
wrong on every sample, while a car that spins part way through a log breaks the relations only
from there on."""
YAW_SCALE_NOTE = (0.78, 1.15)
"""r / (R_eff (omega_right - omega_left) / t_w) outside this (but inside YAW_RATIO) is said in a
note: healthy logs give 0.99-1.01 in the median (0.81 braking hard in a bend), a yaw-rate factor
typed 30 % wrong gives 1.3 or 0.77."""
FROZEN_TIME = 0.5
"""s: an inertial column that repeats one value bit for bit this long is frozen there (sensor
noise makes a live one change every sample; a steering angle or a speed may rightly stand still)."""
FROZEN_CHECKED = ("ay", "r")
FROZEN_SHARE = 0.5
"""A column frozen over this share of the log or more is judged whole (a synthetic or standing log)."""
MIN_YAW_RATE = 0.03
"""rad/s: yaw rates below this say little about a ratio."""
MIN_LATERAL = 0.5
"""m/s^2: |r v_x| below this says little about a_y's unit."""
LINEAR_LATERAL = 4.0
MAX_LATERAL = 15.0
"""m/s^2: r v_x beyond what any tyre holds is a spinning car (its yaw rate no path curvature), not
a sample to judge a_y's unit by."""
SPEED_CAUSES = (("column 'vx' looks like km/h", 3.6), ("column 'vx' looks like mph", 2.23694))
"""(cause, factor by which it grows the ratio)."""
YAW_CAUSES = (("column 'r' looks like deg/s", 180 / math.pi),)
LATERAL_CAUSES = (("column 'r' looks like deg/s", 180 / math.pi), ("column 'vx' looks like km/h", 3.6),
                  ("column 'vx' looks like mph", 2.23694), ("column 'ay' looks like g", 9.80665))
"""(cause, factor by which it shrinks a_y / (r v_x))."""
STEER_CAUSES = (("column 'delta' looks like degrees", 180 / math.pi),
                ("column 'delta' looks like the steering-wheel angle (ratio ~15; map it with factor = 1/ratio)", 15.0),
                ("column 'delta' looks like the steering-wheel angle in degrees", 15.0 * 180 / math.pi),
                ("column 'r' looks like deg/s", math.pi / 180))
"""(cause, factor by which it shrinks r / r_model)."""
WHEELS = ("omega_fl", "omega_fr", "omega_rl", "omega_rr")


HEAD_SPAN = 600.0
"""s: a log read in chunks is judged on its first ten minutes (a wrong unit is wrong on every
sample; the physics check is the slow part of reading)."""


def check_units_of_head(source, vehicle: Mapping[str, float], driven_axle: str | None = None,
                        notes: list[str] | None = None) -> list[str]:
    """:func:`check_units` on the first HEAD_SPAN s of ``source`` (a ``harness.logs.stream.LogSource``)."""
    return check_units(next(source.chunks(max(2, round(HEAD_SPAN / source.sample_time)))), vehicle,
                       driven_axle, notes)


def check_units(log: Log, vehicle: Mapping[str, float], driven_axle: str | None = None,
                notes: list[str] | None = None) -> list[str]:
    """Raise LogError (one line: file, relation, likely cause) when the log's physics says a unit
    is wrong; return "column (why)" for each input column no relation could judge. ``driven_axle``
    ("front", "rear", None: unknown) chooses the wheels; ``notes`` receives a line for each frozen
    stretch and for a yaw rate scaled far from the wheels'."""
    need = ("delta", "vx", "ay", "r")
    if any(name not in log for name in need):
        return []
    notes = [] if notes is None else notes
    window = max(1, round(SMOOTHING / log.sample_time))
    live = {name: ~_frozen(np.asarray(log[name], dtype=float), log, name, notes) if name in FROZEN_CHECKED
            else np.ones(len(log), dtype=bool) for name in need}
    delta, vx, ay, r = (np.where(live[name], _smoothed(np.asarray(log[name], dtype=float), window), np.nan)
                        for name in need)
    judged: set[str] = set()
    wheels = all(name in log for name in WHEELS)
    if wheels:
        rolling, yaw = _free_axle(log, vehicle, vx, r, window, driven_axle)
        moving = np.isfinite(vx) & np.isfinite(rolling) & (rolling > MIN_SPEED)
        _judge(log, "v_x / (R_eff mean |omega|)", vx, rolling, moving, SPEED_RATIO, SPEED_CAUSES, judged, "vx")
        turning = moving & np.isfinite(r) & (np.abs(yaw) > MIN_YAW_RATE)
        ratio = _judge(log, "r / (R_eff (omega_right - omega_left) / t_w)", r, yaw, turning, YAW_RATIO, YAW_CAUSES,
                       judged, "r")
        if ratio is not None and not YAW_SCALE_NOTE[0] <= ratio <= YAW_SCALE_NOTE[1]:
            notes.append(f"r / (R_eff (omega_right - omega_left) / t_w) = {ratio:.3g}: the yaw rate reads "
                         f"{abs(ratio - 1):.0%} {'above' if ratio > 1 else 'below'} the wheel speeds': a scaling "
                         f"error (a factor in the DBC or the channel map)? The estimates will be off")
    speed = rolling if wheels else np.abs(vx)
    moving = np.isfinite(speed) & (speed > MIN_SPEED)
    centripetal = r * vx
    lateral = moving & np.isfinite(ay) & np.isfinite(centripetal) & (np.abs(centripetal) > MIN_LATERAL) \
        & (np.abs(centripetal) < MAX_LATERAL)
    if _judge(log, "a_y / (r v_x)", ay, centripetal, lateral, LATERAL_RATIO, LATERAL_CAUSES, judged, "ay",
              invert=True) is not None:
        judged |= {"r", "vx"}
    predicted = bicycle_yaw_rate(delta, speed, vehicle, log.sample_time)
    linear = moving & np.isfinite(r) & np.isfinite(predicted) & (np.abs(predicted) > MIN_YAW_RATE) \
        & (np.abs(ay) < LINEAR_LATERAL) & (np.abs(centripetal) < LINEAR_LATERAL)
    if _judge(log, "r / r_model(delta)", r, predicted, linear, STEER_RATIO, STEER_CAUSES, judged, "delta",
              invert=True) is None:   # a log beyond the linear range: the tyres saturate, a wider band
        steering = moving & np.isfinite(r) & np.isfinite(predicted) & (np.abs(predicted) > MIN_YAW_RATE) \
            & (r * predicted > 0)
        _judge(log, "r / r_model(delta) beyond the linear range", r, predicted, steering, SATURATED_STEER_RATIO,
               STEER_CAUSES, judged, "delta", invert=True)
    return [f"{name} (too little {'motion' if name != 'delta' else 'steering in the linear range'})"
            for name in need if name not in judged]


def _free_axle(log: Log, vehicle: Mapping[str, float], vx: np.ndarray, r: np.ndarray, window: int,
               driven_axle: str | None) -> tuple[np.ndarray, np.ndarray]:
    """(rolling speed R_eff mean |omega|, yaw rate R_eff (omega_right - omega_left) / t_w) of the
    free axle: the one the drive does not reach when ``driven_axle`` names the other; else, at each
    sample, the axle rolling nearest v_x (whose wheels neither spin under drive torque nor lock
    under braking) and the axle whose yaw rate is nearest r (an unloaded inner wheel of the
    driven axle spins up in a long corner; a wrong unit or sign of r is far from both)."""
    omega = {name: _smoothed(np.asarray(log[name], dtype=float), window) for name in WHEELS}
    radius, track = vehicle["wheel_radius"], vehicle["track_width"]
    axles = [(radius * (np.abs(omega[left]) + np.abs(omega[right])) / 2, radius * (omega[right] - omega[left]) / track)
             for left, right in (("omega_fl", "omega_fr"), ("omega_rl", "omega_rr"))]
    (front, front_yaw), (rear, rear_yaw) = axles
    if driven_axle is not None:
        return (rear, rear_yaw) if driven_axle == "front" else (front, front_yaw)
    with np.errstate(divide="ignore", invalid="ignore"):
        front_rolls = np.abs(np.log(np.abs(vx / front))) <= np.abs(np.log(np.abs(vx / rear)))
        front_yaws = np.abs(np.log(np.abs(r / front_yaw))) <= np.abs(np.log(np.abs(r / rear_yaw)))
    return np.where(front_rolls, front, rear), np.where(front_yaws, front_yaw, rear_yaw)


def _frozen(raw: np.ndarray, log: Log, name: str, notes: list[str]) -> np.ndarray:
    """Where ``raw`` repeats one value bit for bit for FROZEN_TIME or longer (a note each stretch),
    when that is less than FROZEN_SHARE of the log: a log mostly constant (synthetic, or a car
    standing) is judged whole, as before."""
    same = np.concatenate([[False], raw[1:] == raw[:-1]])
    frozen = np.zeros(len(raw), dtype=bool)
    minimum = max(2, round(FROZEN_TIME / log.sample_time))
    t = np.asarray(log["t"], dtype=float)
    said, start = [], None
    for k, repeated in enumerate([*same, False]):
        if repeated and start is None:
            start = k - 1
        elif not repeated and start is not None:
            if k - start >= minimum:
                frozen[start:k] = True
                said.append(f"column '{name}' repeats one value for {(k - start) * log.sample_time:.2f} s from "
                            f"t = {t[start]:.2f} s: a frozen sensor or CAN signal? (its unit was judged on the rest)")
            start = None
    if np.mean(frozen) >= FROZEN_SHARE:
        return np.zeros(len(raw), dtype=bool)
    notes += said
    return frozen


def _smoothed(x: np.ndarray, window: int) -> np.ndarray:
    """``x`` averaged over ``window`` samples (centred), NaN where a NaN was in reach: the ratios are
    taken of smoothed signals, so sensor noise cannot fake a unit error on a gently driven log."""
    finite = np.isfinite(x)
    mean = segments.smoothed(np.where(finite, x, 0.0), window)
    return np.where(segments.smoothed(finite.astype(float), window) > 0.999, mean, np.nan)


def bicycle_yaw_rate(delta: np.ndarray, speed: np.ndarray, vehicle: Mapping[str, float], dt: float) -> np.ndarray:
    """The yaw rate of the linear 2-DOF bicycle model driven by ``delta`` (rad) at ``speed`` (m/s),
    stepped by its exact solution over each sample (stable at any speed); NaN inputs (and speeds
    below 1 m/s) hold it. The steady states and transition matrices of all samples are computed
    at once; only the two-number recursion runs sample by sample.

    A vehicle file's first guesses may make the model oversteer (b C_r < a C_f), and an oversteering
    model diverges above its critical speed: the rear stiffness is raised to neutral steer at least
    (a C_f / b), which keeps the prediction within the check's wide band of any real car."""
    m, iz = vehicle["mass"], vehicle["yaw_inertia"]
    a, b = vehicle["cg_to_front_axle"], vehicle["cg_to_rear_axle"]
    cf = vehicle["cornering_stiffness_front"]
    cr = max(vehicle["cornering_stiffness_rear"], a * cf / b)
    delta, speed = np.asarray(delta, dtype=float), np.asarray(speed, dtype=float)
    used = np.isfinite(delta) & np.isfinite(speed) & (speed >= 1.0)
    v = np.where(used, speed, 1.0)
    A = np.empty((len(v), 2, 2))
    A[:, 0, 0] = -(cf + cr) / (m * v)
    A[:, 0, 1] = (b * cr - a * cf) / (m * v) - v
    A[:, 1, 0] = (b * cr - a * cf) / (iz * v)
    A[:, 1, 1] = -(a * a * cf + b * b * cr) / (iz * v)
    B = np.stack([np.full(len(v), cf / m), np.full(len(v), a * cf / iz)], axis=1) * np.where(used, delta, 0.0)[:, None]
    steady = -np.linalg.solve(A, B[:, :, None])[:, :, 0]
    decay = _expm2(A * dt)
    out = np.full(len(delta), np.nan)
    x0 = x1 = 0.0
    for k in np.flatnonzero(used).tolist():
        (d00, d01), (d10, d11) = decay[k].tolist()
        s0, s1 = steady[k].tolist()
        x0, x1 = s0 + d00 * (x0 - s0) + d01 * (x1 - s1), s1 + d10 * (x0 - s0) + d11 * (x1 - s1)
        out[k] = x1
    return out


def _expm2(M: np.ndarray) -> np.ndarray:
    """e^M of each 2 x 2 matrix of ``M`` (n x 2 x 2), by scaling and squaring of a short series."""
    norm = np.abs(M).sum(axis=2).max()
    squarings = max(0, math.ceil(math.log2(max(norm, 1e-12) / 0.25)))
    S = M / 2**squarings
    S2 = S @ S
    E = np.eye(2) + S + S2 / 2 + S2 @ S / 6 + S2 @ S2 / 24
    for _ in range(squarings):
        E = E @ E
    return E


def _judge(log: Log, relation: str, signal: np.ndarray, predicted: np.ndarray, mask: np.ndarray,
           expected: tuple[float, float], causes, judged: set[str], column: str, invert: bool = False) -> float | None:
    """Judge one relation on the ``mask``ed samples (its median ratio, None when it could not);
    LogError when the median ratio ``signal / predicted`` lies outside ``expected``."""
    if np.count_nonzero(mask) < MIN_SAMPLES:
        return None
    ratios = signal[mask] / predicted[mask]
    ratio = float(np.median(ratios))
    agreeing = float(np.mean((ratios >= expected[0]) & (ratios <= expected[1])))
    if not expected[0] <= ratio <= expected[1] and agreeing < AGREEING:
        raise LogError(f"{log.source}: {relation} = {ratio:.3g} over {np.count_nonzero(mask)} samples: expected "
                       f"{expected[0]:g} to {expected[1]:g}; {_cause(ratio, causes, invert)} "
                       f"(--no-unit-check to run anyway)")
    judged.add(column)
    return ratio


def _cause(ratio: float, causes, invert: bool = False) -> str:
    """The cause whose factor brings ``ratio`` nearest to 1 (on a log scale); none does for a ratio
    of 0 (a signal that stays 0 where motion is predicted)."""
    def miss(factor: float) -> float:
        scaled = abs(ratio) * (factor if invert else 1 / factor)
        return abs(math.log(scaled)) if scaled > 0 else math.inf
    name, factor = min(causes, key=lambda cause: miss(cause[1]))
    return name if miss(factor) < 0.5 else "a unit or a sign is wrong"

