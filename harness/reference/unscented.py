"""Reference aukf and ukf (docs/methods.md, seed 002 §2, §3 and §5 defaults): the 3-DOF
model with four-wheel kinematics, HSRI tyres and load transfer (1)-(8), the scaled UT (10)-(11),
the UKF (12)-(14) with the points not redrawn, and (aukf) the sub-optimal Sage-Husa estimator of q
and Q (15a)-(15b) with the §2.10 safeguard and
the ceiling process_noise_max; beyond the spec, no noise learnt from a sample the monitor block
flags and a restart when the estimate leaves the plausible envelope. NumPy only.

The sigma points are propagated and weighted literally, in the difference form of C6, in
``numpy.longdouble`` (64-bit mantissa on x86-64): with alpha = 0.001 the weights are about +-1e6,
and the extra 11 bits keep this literal form an accurate oracle for the generated C, which
evaluates the same sums in a rearranged, cancellation-free form.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vsegen.harness.reference import blocks
from vsegen.harness.reference.monitor_block import Checks

LD = np.longdouble
STATE = ("u", "v", "gamma", "moment", "ax", "ay")
COVARIANCE = blocks.upper_names("P", STATE)
OUTPUTS = ("beta", "vx", "vy", "r", "yaw_moment", "ax", "ay", "status")
WHEEL_SPEEDS = ("omega_fl", "omega_fr", "omega_rl", "omega_rr")
CHECKS = Checks(consistency=True, linear_range=True)
"""Beyond the spec: the input monitors, the consistency monitor of the innovations, the linear-range flag."""
AIR_DENSITY = 1.2
N = 6
ADHESION_FLOOR = 1.0
"""N: the adhesion mu F_z is bent smoothly to this when a wheel lifts (F_z <= 0)..."""
ADHESION_ROUNDING = 100.0
"""N: ...over this width (the model's three_dof.adhesion says why it is smooth)."""


@dataclass(frozen=True)
class Variant:
    """The reference shape (``names``, ``init``, ``step``) for one of the two tables."""

    table: str
    adaptive: bool

    def method_inputs(self, config) -> tuple[str, ...]:
        """What the model reads (every wheel speed in the wheel-speed mode)."""
        wheels = WHEEL_SPEEDS if config.settings(self.table)["longitudinal_force"] == "wheel_speeds" else ()
        return ("delta", "vx", "ax", "ay", "r", *wheels)

    def monitors(self, config):
        """The monitor block (``harness.reference.monitor_block``)."""
        return CHECKS.block(self.method_inputs(config), config.settings(self.table))

    def names(self, config):
        extra = ((*(f"qmean_{n}" for n in STATE), *(f"qvar_{n}" for n in STATE), "fading")
                 if self.adaptive else ())
        block = self.monitors(config)
        return block.inputs, (*STATE, *COVARIANCE, *extra, *block.states, "hold_reason", *block.segment), OUTPUTS

    def init(self, config, u0):
        s, block = config.settings(self.table), self.monitors(config)
        inputs = dict(zip(block.inputs, u0))
        first, holding = blocks.first_sample(config.limits, inputs, s["vx_min"], s["vx_resume"], block.monitored)
        x0 = [min(max(first["vx"], s["vx_min"]), config.limits["vx_max"]), 0, 0, 0, 0, 0]
        extra = [0.0] * N + list(s["process_noise"]) + [s["forgetting_factor"]] if self.adaptive else []
        entries = block.initial(first)
        return np.array(x0 + blocks.packed(np.diag(s["initial_covariance"])) + extra
                        + [entries[k] for k in block.states] + [2 * holding]
                        + [entries[k] for k in block.segment], dtype=float)

    def step(self, config, state, u):
        s, block = config.settings(self.table), self.monitors(config)
        input_names, state_names, _ = self.names(config)
        x = dict(zip(state_names, state))
        inputs = dict(zip(input_names, u))
        active, status, ok = blocks.hold_rule(config.limits, inputs, s["vx_min"], s["vx_resume"],
                                              x["hold_reason"] > 0.5, block.monitored)
        watched, flags = block.watch_inputs(x, inputs, ok, active, config.sample_time, config.vehicle, config.limits)
        if not active:       # hold; hold_reason = 2 marks a low-speed hold, 1 an invalid input
            held = dict(x, hold_reason=2.0 if status & blocks.LOW_SPEED else 1.0) | watched
            return (np.array([held[k] for k in state_names]),
                    np.array([0.0, x["u"], x["v"], x["gamma"], x["moment"], x["ax"], x["ay"],
                              float(status)]))
        if x["hold_reason"] > 1.5:  # back from a low-speed hold: restart here (the held speed is stale)
            x = dict(zip(state_names, self.init(config, u)))
        X = np.array([x[k] for k in STATE], dtype=LD)
        P = blocks.unpacked([x[k] for k in COVARIANCE], N).astype(LD)
        if self.adaptive:
            q = np.array([x[f"qmean_{n}"] for n in STATE], dtype=LD)
            Q = np.diag(np.array([x[f"qvar_{n}"] for n in STATE], dtype=LD))
        else:
            q, Q = np.zeros(N, dtype=LD), np.diag(np.array(s["process_noise"], dtype=LD))
        R = np.diag(np.array(s["measurement_noise"], dtype=LD))
        wheels = (np.array([inputs[w] for w in WHEEL_SPEEDS], dtype=LD)
                  * LD(config.vehicle["wheel_radius"])
                  if s["longitudinal_force"] == "wheel_speeds" else None)

        # (10), (11): sigma points and weights
        alpha, beta, kappa = LD(s["ut_alpha"]), LD(s["ut_beta"]), LD(s["ut_kappa"])
        tau = alpha ** 2 * (N + kappa) - N
        wm = np.full(2 * N + 1, 1 / (2 * (N + tau)), dtype=LD)
        wc = wm.copy()
        wm[0] = tau / (N + tau)
        wc[0] = wm[0] + 1 - alpha ** 2 + beta
        root, repaired = cholesky(P)
        columns = np.sqrt(N + tau) * root
        chi = np.column_stack([X, X[:, None] + columns, X[:, None] - columns])

        # (12): propagate, add q; mean and covariance in difference form (C6)
        F = process(config, s, chi, LD(inputs["delta"]), wheels)
        points = F + q[:, None]
        mean = points[:, 0] + (points[:, 1:] - points[:, :1]) @ wm[1:]
        deviations = points - mean[:, None]
        spread = (deviations * wc) @ deviations.T
        P_pred = spread + Q

        # (13), (14): Z = [a_x, a_y, gamma], r = 0
        Z = points[[4, 5, 2], :]
        z_hat = Z[:, 0] + (Z[:, 1:] - Z[:, :1]) @ wm[1:]
        z_dev = Z - z_hat[:, None]
        P_zz = (z_dev * wc) @ z_dev.T + R
        P_xz = (deviations * wc) @ z_dev.T
        K = P_xz @ _inverse3(P_zz)
        ay = blocks.roll_corrected(inputs["ay"], s["roll_gradient"])
        eps = np.array([inputs["ax"], ay, inputs["r"]], dtype=LD) - z_hat
        X_new = mean + K @ eps
        P_new = P_pred - K @ P_zz @ K.T

        new = {**dict(zip(STATE, X_new)), **dict(zip(COVARIANCE, blocks.packed(P_new)))}
        monitor, judgement, first_inconsistent = block.judge_model(x, eps, config.sample_time, inputs["ay"], z_hat[1])
        if self.adaptive:      # (15a), (15b), §2.10; beyond the spec: no sample the monitors flag
            learnt = self._sage_husa(s, x, q, Q, mean, spread, X_new, P_new, K @ eps)
            new.update(learnt if not (flags or judgement) else {k: x[k] for k in learnt})
        new["hold_reason"] = 0.0
        status |= blocks.COVARIANCE_REPAIRED if repaired else 0
        new.update(monitor)                         # beyond the spec: the monitor block's model checks
        status |= judgement
        if _leaves_the_envelope(s, X_new, inputs["vx"]) or first_inconsistent:
            new = dict(zip(state_names, self.init(config, u)), hold_reason=0.0, **monitor)   # restart here
            X_new = np.array([new[k] for k in STATE], dtype=LD)
            status |= blocks.FILTER_RESTARTED
        new.update(watched)
        status |= flags
        output = [np.arctan2(X_new[1], X_new[0]), *X_new[[0, 1, 2, 3, 4, 5]], status]
        return (np.array([new[k] for k in state_names], dtype=float),
                np.array(output, dtype=float))


    @staticmethod
    def _sage_husa(s, x, q, Q, mean, spread, X_new, P_new, gain) -> dict:
        """(15a), (15b) with the floor and the cap: the next noise mean, variances and fading."""
        f = LD(s["forgetting_factor"])
        d = (1 - f) / (1 - LD(x["fading"]))
        q_new = (1 - d) * q + d * (X_new - (mean - q))
        bracket = np.outer(gain, gain) + P_new - spread
        Q_new = np.diag((1 - d) * Q + d * bracket)
        if s["noise_safeguard"] == "floor":
            Q_new = np.maximum(Q_new, 1e-3 * np.array(s["process_noise"], dtype=LD))
        Q_new = np.minimum(Q_new, np.array(s["process_noise_max"], dtype=LD))
        return {**{f"qmean_{n}": q_new[i] for i, n in enumerate(STATE)},
                **{f"qvar_{n}": Q_new[i] for i, n in enumerate(STATE)},
                "fading": LD(x["fading"]) * f}

def _leaves_the_envelope(s, X, vx: float) -> bool:
    """Beyond the spec: the estimate is implausible (speed far from the measured one, or a
    sideslip beyond restart_sideslip) and the filter restarts."""
    speed_error, sideslip = s["restart_speed_error"], s["restart_sideslip"]
    return bool((speed_error > 0 and abs(X[0] - vx) > speed_error)
                or (sideslip > 0 and abs(np.arctan2(X[1], X[0])) > sideslip))


def _inverse3(A):
    """Inverse of a 3 x 3 matrix by its adjugate, in the matrix's precision (LAPACK has no
    long double)."""
    cof = np.empty((3, 3), dtype=A.dtype)
    for i in range(3):
        for j in range(3):
            rows = [r for r in range(3) if r != i]
            cols = [c for c in range(3) if c != j]
            (r0, r1), (c0, c1) = rows, cols
            minor = A[r0, c0] * A[r1, c1] - A[r0, c1] * A[r1, c0]
            cof[i, j] = (-1) ** (i + j) * minor
    return cof.T / (A[0, :] @ cof[0, :])


def cholesky(P):
    """(L, repaired): Cholesky-Banachiewicz of P + diag(eps_i), eps_i = 1e-9 max(1, P_ii) (§2.11
    with the jitter per entry, as the state mixes units); if a pivot j is below eps_j / 2 the
    covariance is repaired to diag(max(P_ii, 0) + eps_i)."""
    n = P.shape[0]
    eps = LD(1e-9) * np.maximum(LD(1), np.diag(P))
    A = P + np.diag(eps)
    L = np.zeros_like(A)
    for j in range(n):
        pivot = A[j, j] - np.sum(L[j, :j] ** 2)
        if pivot < eps[j] / 2:
            return np.diag(np.sqrt(np.maximum(np.diag(P), 0) + eps)), True
        L[j, j] = np.sqrt(pivot)
        for i in range(j + 1, n):
            L[i, j] = (A[i, j] - np.sum(L[i, :j] * L[j, :j])) / L[j, j]
    return L, False


def process(config, s, X, delta, rolling):
    """(8) for every column of X = [u, v, gamma, Gamma, a_x, a_y]: Euler, with Gamma, a_x, a_y
    from the HSRI tyre forces at X (2)-(7); ``rolling`` = r omega of fl, fr, rl, rr or None for
    free rolling (S_x = 0, a_x a random walk)."""
    v = config.vehicle
    m, iz = LD(v["mass"]), LD(v["yaw_inertia"])
    a, b = LD(v["cg_to_front_axle"]), LD(v["cg_to_rear_axle"])
    t, h, g = LD(v["track_width"]), LD(v["cg_height"]), LD(blocks.GRAVITY)
    T = LD(config.sample_time)
    mu, cx, floor = LD(s["friction"]), LD(s["longitudinal_stiffness"]), LD(s["slip_speed_floor"])
    cy = np.array([v["cornering_stiffness_front"]] * 2 + [v["cornering_stiffness_rear"]] * 2,
                  dtype=LD)[:, None] / 2
    u, vy, gamma, moment, ax, ay = X
    L = a + b
    # (5) wheel-centre velocities, then the wheel frame (delta on the front wheels only)
    u_c = np.array([u - gamma * t / 2, u + gamma * t / 2, u - gamma * t / 2, u + gamma * t / 2])
    v_c = np.array([vy + gamma * a, vy + gamma * a, vy - gamma * b, vy - gamma * b])
    steer = np.array([delta, delta, 0, 0], dtype=LD)[:, None]
    cos_d, sin_d = np.cos(steer), np.sin(steer)
    u_x = u_c * cos_d + v_c * sin_d
    v_y = -u_c * sin_d + v_c * cos_d
    # (3), (4) slip ratios
    if rolling is None:
        s_x = np.zeros_like(u_x)
        s_y = v_y / np.maximum(u_x, floor)
    else:
        r_omega = rolling[:, None]
        s_x = (r_omega - u_x) / np.maximum(r_omega, floor)
        s_y = v_y / np.maximum(r_omega, floor)
    # (7) loads
    static = np.array([b, b, a, a], dtype=LD)[:, None] * m * g / (2 * L)
    pitch = np.array([-1, -1, 1, 1], dtype=LD)[:, None] * m * ax * h / (2 * L)
    roll = np.array([-b / t, b / t, -a / t, a / t], dtype=LD)[:, None] * m * ay * h / L
    grip = mu * (static + pitch + roll)
    # (2) HSRI, lambda divided by the adhesion: a smooth max(mu F_z, ADHESION_FLOOR)
    adhesion = (grip + ADHESION_FLOOR
                + np.sqrt((grip - ADHESION_FLOOR) ** 2 + LD(ADHESION_ROUNDING) ** 2)) / 2
    lam = np.sqrt((cx * s_x) ** 2 + (cy * s_y) ** 2) / adhesion
    f = np.where(lam <= 0.5, LD(1), (lam - LD(0.25)) / np.maximum(lam, 0.5) ** 2)
    f_x, f_y = cx * s_x * f, -cy * s_y * f
    # (1) body-frame forces, moment, accelerations
    F_X = f_x * cos_d - f_y * sin_d
    F_Y = f_x * sin_d + f_y * cos_d
    Gamma = (a * (F_Y[0] + F_Y[1]) - b * (F_Y[2] + F_Y[3])
             + t / 2 * (F_X[1] - F_X[0]) + t / 2 * (F_X[3] - F_X[2]))
    if rolling is None:
        ax_next = ax
    else:
        ax_next = (F_X.sum(axis=0) - AIR_DENSITY * LD(s["drag_area"]) * u * u / 2) / m
    return np.array([u + T * (ax + vy * gamma), vy + T * (ay - u * gamma), gamma + T * moment / iz,
                     Gamma, ax_next, F_Y.sum(axis=0) / m])
