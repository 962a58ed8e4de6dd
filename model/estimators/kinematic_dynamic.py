"""The kinematic/dynamic sideslip machinery of seed 000 shared by the switching and fusion
estimators: the state layout, the pre-processing (docs/methods.md, seed 000 §2.2, §2.3, §2.6:
prefilter, reliability checks with hold-last-valid and time-out, median), the initial state
(§2.9) and the hold rule (§2.10). Each estimator adds its schemes. Beyond the paper, a measured
a_y can be corrected for body roll (``roll_gradient``: body-fixed sensors), for every use of a_y.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from vsegen.model import filters, signals, status
from vsegen.model.bicycle import stability_factor
from vsegen.model.calibration import Parameters
from vsegen.model.estimator import BEYOND_LINEAR, CheckSegment, Tunable
from vsegen.model.estimators import kf2dof
from vsegen.model.guard import Guard, first_sample, hold, input_guard, model_speed, plausibility, previous_inputs
from vsegen.model.input_checks import frozen
from vsegen.model.layout import Layout
from vsegen.model.monitor_block import Checks
from vsegen.model.schema import ROLL_CORRECTION, Field, choice, positive
from vsegen.model.sensors import roll_corrected
from vsegen.model.signals import Signal

KINEMATIC_INPUTS = ("ay", "r")
"""The inputs the kinematic integrator v_y += T (a_y - r v_x - c) reads beside the speed."""
_KF_ESTIMATES = (Signal("vy", "m/s", "KF lateral velocity"), Signal("r", "rad/s", "KF yaw rate"))
_KF_COVARIANCE_DOC = "KF covariance entry (upper triangle, row by row)"
DYN, KIN = 0, 1
STATUS_BITS = (status.LOW_SPEED, status.INVALID_INPUT, status.REFERENCE_SUSPECT)
"""What seed 000's estimators can raise beside their monitor block's bits: the hold rule's bits and
the reliability checks' time-out."""

YAW_RATE_CHECKS = ("reference", "yaw_acceleration")
KINEMATIC_DYNAMIC_FIELDS: tuple[Field, ...] = (
    choice("prefilter", ("printed", "bessel"), "a_y prefilter: the paper's printed "
           "10000/(s^2+200s+10000) or a phase-normalised 2nd-order Bessel at prefilter_omega"),
    positive("prefilter_omega", "rad/s", "Bessel cut-off (prefilter = \"bessel\" only)"),
    positive("median_span", "s", "median window span (odd length 2 round(span/2T) + 1)"),
    positive("yaw_rate_band", "rad/s", "half-width of the credible band around r_ref"),
    choice("yaw_rate_check", YAW_RATE_CHECKS, "the yaw-rate reliability check: against the "
           "steady-state bicycle reference r_ref (the paper, A5; wrong at the grip limit, where it "
           "rejects genuine samples) or, beyond the paper, a physical bound on the yaw "
           "acceleration: |r - r_last| <= yaw_rate_jump + yaw_acceleration_max (n + 1) T after n "
           "rejections", default="reference"),
    positive("yaw_acceleration_max", "rad/s^2", "largest yaw acceleration a car reaches "
             "(yaw_rate_check = \"yaw_acceleration\" only)", default=5.0),
    positive("yaw_rate_jump", "rad/s", "sample-to-sample gyro noise allowance "
             "(yaw_rate_check = \"yaw_acceleration\" only)", default=0.1),
    positive("lateral_acceleration_band", "m/s^2", "half-width of the band around vx r"),
    positive("reference_timeout", "s", "after this long of continuous rejection, accept again"),
    positive("threshold", "m/s^2", "switching threshold a_yT on |a_y,f|"),
    ROLL_CORRECTION,
)
"""Seed 000's pre-processing and switching settings (docs/methods.md, seed 000 §3); each estimator
adds its monitor block's (``model.monitor_block``)."""


def _checks_against(kind: str):
    return lambda settings: settings["yaw_rate_check"] == kind


YAW_RATE_CHECK_TUNABLES = {
    "yaw_rate_band": Tunable(0.05, 1.0, when=_checks_against("reference"), regime=BEYOND_LINEAR),
    "yaw_acceleration_max": Tunable(1.0, 20.0, when=_checks_against("yaw_acceleration"), regime=BEYOND_LINEAR),
    "yaw_rate_jump": Tunable(0.03, 0.5, when=_checks_against("yaw_acceleration"), regime=BEYOND_LINEAR),
}
"""What ``tune`` may search of the yaw-rate check, for the configured kind of check."""


def window(params: Parameters, table: str) -> int:
    """Median window length N (odd) at the configured sample time."""
    numeric = params.numeric
    return filters.median_window(1.0 / numeric.sample_time, numeric.settings(table)["median_span"])


def states(n_median: int, kf: kf2dof.KalmanState, extra: tuple[Signal, ...] = (),
           monitors: tuple[Signal, ...] = (), segment: tuple[Signal, ...] = ()) -> Layout:
    """The state layout; ``kf`` the KF's entries, ``extra`` an estimator's own entries (0 at init,
    kept while holding), ``monitors`` its monitor block's model checks', ``segment`` its input
    checks' (last; ``model.monitor_block``)."""
    return Layout((
        Signal("ay_m_1", "m/s^2", "prefilter input one sample back"),
        Signal("ay_m_2", "m/s^2", "prefilter input two samples back"),
        Signal("ay_b_1", "m/s^2", "prefilter output one sample back"),
        Signal("ay_b_2", "m/s^2", "prefilter output two samples back"),
        *(Signal(f"ay_b_hist_{i}", "m/s^2", f"median buffer: a_y,b {i} samples back")
          for i in range(1, n_median)),
        Signal("r_last", "rad/s", "last accepted yaw rate (= the checked r of the last sample)"),
        Signal("ay_last", "m/s^2", "last accepted a_y,b (= the checked a_y of the last sample)"),
        Signal("r_rejections", "-", "consecutive yaw-rate rejections"),
        Signal("ay_rejections", "-", "consecutive a_y rejections"),
        Signal("mode", "-", "0 dynamic, 1 kinematic"),
        Signal("vy_kin", "m/s", "kinematic integrator"),
        *kf.signals,
        *kf.covariance_signals,
        Signal("delta_prev", "rad", "last plausible steer angle"),
        Signal("vx_prev", "m/s", "last plausible speed"),
        *monitors,
        signals.HOLDING,
        *extra,
        *segment,
    ))


def prefilter(params: Parameters, table: str) -> filters.Biquad:
    """The configured a_y prefilter, Tustin-discretised at the sample time."""
    settings = params.numeric.settings(table)
    design = (filters.printed_prefilter() if settings["prefilter"] == "printed"
              else filters.bessel_prefilter(settings["prefilter_omega"]))
    return filters.tustin_biquad(*design, params.numeric.sample_time)


def reference_yaw_rate(params: Parameters, delta, vx):
    """r_ref = delta vx / (l (1 + K_s vx^2)) [E7]."""
    vehicle = params.config.vehicle
    l = vehicle["cg_to_front_axle"] + vehicle["cg_to_rear_axle"]
    return delta * vx / (l * (1 + stability_factor(vehicle) * vx * vx))


@dataclass(frozen=True)
class Preprocessed:
    """One sample of shared pre-processing."""

    guard: Guard
    r_checked: ca.SX
    ay_filtered: ca.SX
    """a_y,f: median of the prefiltered a_y (the switching signal)."""
    status: ca.SX
    updates: dict[str, ca.SX]
    """New values of the pre-processing state entries (held while not active)."""
    kinematic_inputs_frozen: ca.SX = ca.SX(0)
    """1 while a_y or r, the kinematic integrator's inputs, is frozen (``model.input_checks.frozen``): the
    model-based scheme must carry the estimate then."""
    checks: CheckSegment | None = None
    """The input checks' segment (``model.monitor_block``), for the structure builder."""


class KinematicDynamic:
    """Layout, settings and helpers of one seed-000 estimator table, with the monitor block of its
    ``checks``."""

    def __init__(self, params: Parameters, table: str, checks: Checks, extra: tuple[Signal, ...] = ()) -> None:
        self.params = params
        self.table = table
        self.settings = params.config.settings(table)
        self.T = params.config.sample_time
        self.n_median = window(params, table)
        self.extra = extra
        self.monitors = checks.block(params.numeric.settings(table))
        self.inputs = self.monitors.inputs
        """The input layout: the KF's inputs and what the monitors read beside them."""
        self.kf = kf2dof.KalmanState(params.numeric.settings(table), self.settings, _KF_ESTIMATES, _KF_COVARIANCE_DOC)
        """The KF's state entries ([vy, r], and the friction scale where it is estimated)."""
        self.layout = states(self.n_median, self.kf, extra, self.monitors.states, self.monitors.segment)
        self.biquad = prefilter(params, table)
        self.timeout = max(1, round(params.numeric.settings(table)["reference_timeout"] / self.T))
        self.vx_min, self.vx_resume = self.settings["vx_min"], self.settings["vx_resume"]
        self.vx_max = params.config.limits["vx_max"]

    def roll_corrected(self, ay_measured):
        """a_y at the CG from a body-fixed accelerometer (``model.sensors.roll_corrected``)."""
        return roll_corrected(ay_measured, self.settings["roll_gradient"])

    def speed(self, vx):
        """vx clamped to [vx_min, vx_max] (the model never sees a smaller or larger speed)."""
        return model_speed(vx, self.vx_min, self.vx_max)

    def guard(self, s: dict, u: dict) -> Guard:
        """The input guard of the sample (``model.guard.input_guard``)."""
        return input_guard(u, self.params.config.limits, self.vx_min, self.vx_resume, s["holding"],
                           self.monitors.monitored)

    def preprocess(self, s: dict, u: dict, guard: Guard | None = None) -> Preprocessed:
        """Filters and reliability checks of the sample, under ``guard`` (default: its
        :meth:`guard`; an estimator built with ``model.guard.symbolic`` passes the symbolic one)."""
        settings = self.settings
        guard = guard or self.guard(s, u)
        ok, active = guard.plausible, guard.active
        ay_m = hold(self.roll_corrected(u["ay"]), ok["ay"], s["ay_m_1"])
        ay_b = filters.biquad_step(self.biquad, ay_m, s["ay_m_1"], s["ay_m_2"], s["ay_b_1"],
                                   s["ay_b_2"])
        vx = self.speed(hold(u["vx"], ok["vx"], self.vx_min))
        r_m = hold(u["r"], ok["r"], s["r_last"])
        if self.params.numeric.settings(self.table)["yaw_rate_check"] == "reference":
            r_ref = reference_yaw_rate(self.params, hold(u["delta"], ok["delta"], 0), vx)
            band = settings["yaw_rate_band"]
        else:   # beyond the paper: a physical bound on the yaw acceleration since the last valid r
            r_ref = s["r_last"]
            band = settings["yaw_rate_jump"] + settings["yaw_acceleration_max"] * self.T * (
                s["r_rejections"] + 1)
        r_check = filters.reliability_check(r_m, r_ref, band, s["r_last"], s["r_rejections"],
                                            self.timeout)
        ay_check = filters.reliability_check(ay_b, vx * r_check.value,
                                             settings["lateral_acceleration_band"], s["ay_last"],
                                             s["ay_rejections"], self.timeout)
        history = [ay_b] + [s[f"ay_b_hist_{i}"] for i in range(1, self.n_median)]
        suspect = ca.logic_or(r_check.forced, ay_check.forced)
        code = guard.status + ca.if_else(ca.logic_and(active, suspect), status.REFERENCE_SUSPECT, 0)
        watched = self.monitors.watch_inputs(s, u, ok, active, settings, self.T, self.params.config.vehicle,
                                                   self.params.config.limits)
        code = code + watched.code

        def keep(name, value):
            return ca.if_else(active, value, s[name])

        updates = {
            "ay_m_1": keep("ay_m_1", ay_m), "ay_m_2": keep("ay_m_2", s["ay_m_1"]),
            "ay_b_1": keep("ay_b_1", ay_b), "ay_b_2": keep("ay_b_2", s["ay_b_1"]),
            **{f"ay_b_hist_{i}": keep(f"ay_b_hist_{i}", history[i - 1])
               for i in range(1, self.n_median)},
            "r_last": keep("r_last", r_check.last), "ay_last": keep("ay_last", ay_check.last),
            "r_rejections": keep("r_rejections", r_check.rejections),
            "ay_rejections": keep("ay_rejections", ay_check.rejections),
            **watched.updates,
        }
        frozen_inputs = frozen.any_frozen(s, settings, self.monitors.check_time(self.T), KINEMATIC_INPUTS)
        return Preprocessed(guard, r_check.value, filters.median(history), code, updates, frozen_inputs,
                            watched.checks)

    def held(self, m: dict, v: dict, plausible: dict | None = None) -> dict:
        """State while holding (§2.10): integrator and KF reset, P = P_0, mode DYN, last
        plausible previous inputs kept (``plausible``: the guard's flags, default computed);
        pre-processing buffers held by ``preprocess``."""
        plausible = plausible or plausibility(v, self.params.config.limits)
        new = dict(m)
        new.update({"vy_kin": ca.SX(0), "vy": ca.SX(0), "mode": ca.SX(DYN), "holding": ca.SX(1),
                    **{n: self.kf.P0[i] for i, n in enumerate(self.kf.covariance)},
                    **previous_inputs(v, plausible, m)})
        return new

    def advanced(self, m: dict, v: dict, changes: dict) -> dict:
        """State after an active step: ``changes`` plus this sample's inputs kept for the next
        prediction. (The checked a_y and r of this sample are ``ay_last`` and ``r_last``.)"""
        new = dict(m)
        new.update(changes)
        new.update({"delta_prev": v["delta"], "vx_prev": v["vx"], "holding": ca.SX(0)})
        return new

    def initial_state(self, u: dict) -> ca.SX:
        """§2.9: filters at their DC steady state for sample 0, r_last = r_0 if inside the band of
        r_ref,0 else r_ref,0, KF at [0, r_0] with P_0, previous inputs = sample 0."""
        first, holding = first_sample(u, self.params.config.limits, self.vx_min, self.vx_resume,
                                      self.monitors.monitored)
        ay0, r0, delta0, vx0 = self.roll_corrected(first["ay"]), first["r"], first["delta"], first["vx"]
        r_ref0 = reference_yaw_rate(self.params, delta0, self.speed(vx0))
        r_last0 = ca.if_else(ca.fabs(r0 - r_ref0) <= self.settings["yaw_rate_band"], r0, r_ref0)
        if self.params.numeric.settings(self.table)["yaw_rate_check"] == "yaw_acceleration":
            r_last0 = r0
        ay_b0 = ay0 * self.biquad.dc_gain
        return self.layout.pack({
            "ay_m_1": ay0, "ay_m_2": ay0, "ay_b_1": ay_b0, "ay_b_2": ay_b0,
            **{f"ay_b_hist_{i}": ay_b0 for i in range(1, self.n_median)},
            "r_last": r_last0, "ay_last": ay_b0, "r_rejections": ca.SX(0),
            "ay_rejections": ca.SX(0), "mode": ca.SX(DYN), "vy_kin": ca.SX(0), **self.kf.initial(r0),
            "delta_prev": delta0, "vx_prev": vx0,
            **self.monitors.initial_entries(first),
            "holding": holding,
            **{entry.name: ca.SX(0) for entry in self.extra},
        })

    def notes(self) -> dict[str, str]:
        b = self.biquad
        return {**kf2dof.zoh_note(self.params, self.table),
                "median_window": f"{self.n_median} samples",
                "prefilter": f"{self.params.numeric.settings(self.table)['prefilter']}, Tustin: "
                             f"n = [{b.n0:.6g}, {b.n1:.6g}, {b.n2:.6g}], d = [1, {b.d1:.6g}, {b.d2:.6g}]"}
