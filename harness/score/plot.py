"""Seed 000 Fig. 8 style plot: beta against the reference, |delta beta| over time, background
shaded where a switching estimator used its dynamic scheme, the KF (``mode`` = 0), where the
estimator held (low speed or an invalid input) and where its status carried any other bit."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from vsegen.harness.logs.table import Log, LogError, runs
from vsegen.harness.project.files import write_atomic
from vsegen.model import status

DYNAMIC = 0


SIGNALS = (("beta", "beta_ref", "sideslip angle β (deg)", "|Δβ| (deg)"),
           ("r", "r_ref", "yaw rate r (deg/s)", "|Δr| (deg/s)"))
"""What is plotted: the first signal every estimate has (estimate, truth, axis labels)."""


def plot(log: Log, estimates: dict[str, Log], out: Path, title: str = "") -> None:
    """Write a PNG with beta (deg) over time and the absolute error (deg) of each estimate (the
    yaw rate in deg/s when an estimate has no beta, e.g. a yaw-rate estimator). A log without the
    truth column (a road log without a reference) shows the estimates and, below, their status."""
    common = [s for s in SIGNALS if all(s[0] in est for est in estimates.values())]
    if not common:
        raise LogError(f"{next(iter(estimates.values())).source}:1: no column to plot: expected "
                       "'beta' or 'r' in every estimate")
    with_truth = [s for s in common if s[1] in log]
    name, truth, label_value, label_error = (with_truth or common)[0]
    truth = truth if with_truth else None
    t = log["t"]
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(9, 5.5),
                                      gridspec_kw={"height_ratios": [3, 2]})
    if truth is not None:
        top.plot(t, np.rad2deg(log[truth]), color="black", lw=1.6, label="reference (truth)")
    for label, est in estimates.items():
        line, = top.plot(t, np.rad2deg(est[name]), lw=1.0, label=label)
        if truth is not None:
            bottom.plot(t, np.abs(np.rad2deg(est[name] - log[truth])), lw=1.0, color=line.get_color(), label=label)
        else:
            bottom.step(t, est["status"], where="post", lw=1.0, color=line.get_color(), label=label)
    if truth is None:
        label_error = "status (0 = OK)"
        title = f"{title} (no reference in the log)".strip()
    _shade_states(next(iter(estimates.values())), t, top, bottom)
    if "off_course" in log and log["off_course"].any():
        first = t[np.argmax(log["off_course"] > 0)]
        for axis in (top, bottom):
            axis.axvline(first, color="red", ls=":", lw=1)
        top.text(first, top.get_ylim()[1], " off course / cone", color="red", va="top", fontsize=8)
    top.set_ylabel(label_value)
    bottom.set_ylabel(label_error)
    bottom.set_xlabel("time (s)")
    top.legend(loc="upper right", fontsize=8)
    top.grid(alpha=0.3)
    bottom.grid(alpha=0.3)
    if title:
        top.set_title(title, fontsize=10)
    fig.tight_layout()
    write_atomic(Path(out), lambda tmp: fig.savefig(tmp, dpi=80))
    plt.close(fig)


HELD = status.LOW_SPEED | status.INVALID_INPUT


def state_spans(est: Log) -> dict[tuple[str, str], np.ndarray]:
    """{(label, colour): mask} of what a plot shades for an estimate: its holds, its KF mode (a
    switching estimator's mode = 0 on a sample it did not hold) and the samples whose status carries
    any other bit; masks that are nowhere true are left out."""
    length = len(est["t"])
    code = np.nan_to_num(est["status"]).astype(int) if "status" in est else np.zeros(length, dtype=int)
    held = (code & HELD) != 0
    spans = {}
    if "mode" in est:
        spans[("dynamic scheme (KF)", "tab:green")] = (est["mode"] == DYNAMIC) & ~held
    spans[("hold (low speed or invalid input)", "0.5")] = held
    spans[("status bit set (estimate suspect)", "tab:orange")] = (code & ~HELD) != 0
    return {key: mask for key, mask in spans.items() if mask.any()}


def _shade_states(est: Log, t: np.ndarray, top, bottom) -> None:
    for (label, color), mask in state_spans(est).items():
        for axis in (top, bottom):
            for run in runs(mask):
                axis.axvspan(t[run.start], t[min(run.stop, len(t) - 1)], color=color, alpha=0.15, lw=0)
        top.fill_between([], [], color=color, alpha=0.15, label=label)


def tuning_plot(scores: list[float], baseline_train: float, tuned_train: float,
                baseline_holdout: float | None, tuned_holdout: float | None, unit: str, out: Path,
                title: str = "") -> None:
    """Write a PNG of a tuning run: each trial's training objective and the best so far, with the
    training and hold-out objectives before and after (over-fitting shows as a hold-out that does
    not follow the training score)."""
    fig, (history, summary) = plt.subplots(1, 2, figsize=(11, 4), gridspec_kw={"width_ratios": [3, 1]})
    finite = np.where(np.isfinite(scores), scores, np.nan)
    history.plot(np.arange(1, len(scores) + 1), finite, ".", color="0.6", label="trial")
    history.plot(np.arange(1, len(scores) + 1), np.fmin.accumulate(np.nan_to_num(finite, nan=np.inf)),
                 "-", color="C0", label="best so far")
    history.axhline(baseline_train, color="C3", linestyle="--", label="before (training)")
    history.set_xlabel("trial")
    history.set_ylabel(f"objective ({unit})")
    history.legend()
    labels, before, after = ["training"], [baseline_train], [tuned_train]
    if baseline_holdout is not None and tuned_holdout is not None:
        labels.append("hold-out")
        before.append(baseline_holdout)
        after.append(tuned_holdout)
    x = np.arange(len(labels))
    summary.bar(x - 0.2, before, 0.4, label="before", color="C3")
    summary.bar(x + 0.2, after, 0.4, label="after", color="C0")
    summary.set_xticks(x, labels)
    summary.legend()
    fig.suptitle(title)
    fig.tight_layout()
    write_atomic(Path(out), lambda tmp: fig.savefig(tmp, dpi=110))
    plt.close(fig)
