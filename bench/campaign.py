"""python -m bench.campaign: how fast vsegen runs long logs and campaigns of logs, in the sections
"Streaming runs" and "Campaigns" of docs/benchmarks.md.

* **Streaming runs**: ``vsegen run`` and ``vsegen score`` on one hour and on ten hours of driving at
  100 Hz (a CSV tiled from simulated manoeuvres), per estimator: wall time and peak memory (the
  command's maximum resident set, from ``os.wait4``).
* **Campaigns**: ``vsegen campaign``'s machinery over 100 logs of 10 min (a third CSV, a third MDF4,
  a third raw-CAN MDF4 decoded with a DBC) x 3 estimators: serially, on a LocalCluster, and on a
  Dask scheduler with two worker processes started here; wall time, throughput (samples per second
  per core, estimator-samples) and the peak memory of each worker; then 10 logs added and the
  campaign run again (only those computed).

The logs are written once under build/bench-campaign/ and reused.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bench import BENCHMARKS, DEFAULT_VEHICLE, REPO
from bench.document import provenance, write_section
from vsegen.harness.logs.table import Log
from vsegen.harness.outputs.estimates import EstimatesWriter
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.sim.scenarios import Case

DATA = REPO / "build" / "bench-campaign"
PIECES = (Case.of("dlc", speed_kmh=60.0), Case.of("dlc", speed_kmh=80.0), Case.of("dlc", speed_kmh=100.0),
          Case.of("sine_steer"), Case.of("hil_sine"), Case.of("continuous_dlc"), Case.of("step_steer"))
"""Simulated manoeuvres that synthetic logs are tiled from, in a random order per log."""
COLUMNS = ("t", "delta", "vx", "ax", "ay", "r", "omega_fl", "omega_fr", "omega_rl", "omega_rr",
           "beta_ref", "vx_ref", "vy_ref", "r_ref")
RUN_ESTIMATORS = ("kf2dof", "switching", "ukf", "pf_improved")
CAMPAIGN_ESTIMATORS = ("kf2dof", "switching", "ukf")
RATE = 100.0
DBC = """VERSION ""

NS_ :

BS_:

BU_: ESC

BO_ 256 Inertial: 8 ESC
 SG_ r : 0|16@1- (0.0001,0) [-3.2768|3.2767] "rad/s" Vector__XXX
 SG_ ay : 16|16@1- (0.001,0) [-32.768|32.767] "m/s^2" Vector__XXX
 SG_ ax : 32|16@1- (0.001,0) [-32.768|32.767] "m/s^2" Vector__XXX

BO_ 257 Steering: 8 ESC
 SG_ delta : 0|16@1- (0.00001,0) [-0.32768|0.32767] "rad" Vector__XXX

BO_ 258 Speed: 8 ESC
 SG_ vx : 0|16@1+ (0.01,0) [0|655.35] "m/s" Vector__XXX

BO_ 260 WheelSpeeds: 8 ESC
 SG_ omega_fl : 0|16@1+ (0.01,0) [0|655.35] "rad/s" Vector__XXX
 SG_ omega_fr : 16|16@1+ (0.01,0) [0|655.35] "rad/s" Vector__XXX
 SG_ omega_rl : 32|16@1+ (0.01,0) [0|655.35] "rad/s" Vector__XXX
 SG_ omega_rr : 48|16@1+ (0.01,0) [0|655.35] "rad/s" Vector__XXX

BO_ 259 Reference: 8 ESC
 SG_ beta_ref : 0|16@1- (0.00001,0) [-0.32768|0.32767] "rad" Vector__XXX
"""
FRAMES = {256: (("r", 1e-4), ("ay", 1e-3), ("ax", 1e-3)), 257: (("delta", 1e-5),), 258: (("vx", 1e-2),),
          260: (("omega_fl", 1e-2), ("omega_fr", 1e-2), ("omega_rl", 1e-2), ("omega_rr", 1e-2)),
          259: (("beta_ref", 1e-5),)}
UNSIGNED = ("vx", "omega_fl", "omega_fr", "omega_rl", "omega_rr")
"""The DBC's frames: id -> (signal, scale) of its little-endian 16-bit fields, in order."""


def pieces(config) -> list[Log]:
    """The simulated manoeuvres, each with the columns COLUMNS."""
    return [Log({name: case.simulate(config, RATE, seed)[name] for name in COLUMNS})
            for seed, case in enumerate(PIECES, start=1)]


TRANSITION = 3.0
"""s: between two manoeuvres every signal goes linearly from one's last sample to the next's first."""


def synthetic_log(parts: list[Log], samples: int, seed: int) -> Log:
    """``samples`` samples at RATE tiled from ``parts`` in a random order (``seed``), joined by
    linear transitions of TRANSITION s (no jumps), time continuous."""
    rng = np.random.default_rng(seed)
    chosen, total = [], 0
    ramp = np.linspace(0.0, 1.0, int(TRANSITION * RATE) + 2)[1:-1]
    while total < samples:
        part = parts[int(rng.integers(len(parts)))]
        if chosen:
            before = chosen[-1]
            chosen.append(Log({name: before[name][-1] + ramp * (part[name][0] - before[name][-1])
                               for name in COLUMNS}))
            total += len(ramp)
        chosen.append(part)
        total += len(part)
    columns = {name: np.concatenate([p[name] for p in chosen])[:samples] for name in COLUMNS}
    columns["t"] = np.arange(samples) / RATE
    return Log(columns)


def write_csv(log: Log, path: Path) -> None:
    """A (long) log as CSV, chunk by chunk."""
    with EstimatesWriter(path, {}) as writer:
        for start in range(0, len(log), 1 << 16):
            writer.write(Log({name: values[start:start + (1 << 16)] for name, values in log.columns.items()}))


def write_mdf(log: Log, path: Path) -> None:
    from asammdf import MDF, Signal

    mdf = MDF(version="4.10")
    mdf.append([Signal(log[name], log["t"], name=name) for name in COLUMNS[1:]])
    mdf.save(path, overwrite=True)


def write_can_mdf(log: Log, path: Path) -> None:
    """A log as a bus-logging MDF4 of the DBC's frames (each 0.1-0.4 ms after its sample)."""
    from asammdf import MDF, Signal
    from asammdf.blocks.source_utils import Source
    from asammdf.blocks.v4_constants import BUS_TYPE_CAN, SOURCE_BUS
    from can.io.mf4 import STD_DTYPE

    stamps, frames = [], []
    for number, (frame_id, fields) in enumerate(FRAMES.items(), start=1):
        frame = np.zeros(len(log), dtype=STD_DTYPE)
        frame["CAN_DataFrame.ID"] = frame_id
        frame["CAN_DataFrame.DLC"] = frame["CAN_DataFrame.DataLength"] = 8
        raw = np.zeros((len(log), 64), dtype=np.uint8)
        for i, (name, scale) in enumerate(fields):
            value = np.round(log[name] / scale)
            signed = name not in UNSIGNED
            raw[:, 2 * i:2 * i + 2] = np.clip(value, -32768 if signed else 0, 32767 if signed else 65535).astype(
                "<i2" if signed else "<u2").view(np.uint8).reshape(-1, 2)
        frame["CAN_DataFrame.DataBytes"] = raw
        stamps.append(log["t"] + 1e-4 * number)
        frames.append(frame)
    order = np.argsort(np.concatenate(stamps), kind="stable")
    source = Source(name="CAN", path="CAN", comment="", source_type=SOURCE_BUS, bus_type=BUS_TYPE_CAN)
    mdf = MDF(version="4.10")
    mdf.append(Signal(np.concatenate(frames)[order], np.concatenate(stamps)[order], name="CAN_DataFrame",
                      source=source))
    mdf.save(path, overwrite=True)


def database(config, count: int, minutes: float, folder: Path) -> list[Path]:
    """``count`` logs of ``minutes`` (CSV, MDF4, raw-CAN MDF4 in turn) in ``folder``, written once."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder.parent / "car.dbc").write_text(DBC)
    parts, paths = None, []
    for i in range(count):
        kind = ("csv", "mf4", "can.mf4")[i % 3]
        path = folder / f"drive_{i:03d}.{kind}"
        if not path.exists():
            parts = parts or pieces(config)
            log = synthetic_log(parts, int(minutes * 60 * RATE), seed=i)
            {"csv": write_csv, "mf4": write_mdf, "can.mf4": write_can_mdf}[kind](log, path)
        paths.append(path)
    return paths


def timed(command: list[str]) -> tuple[float, float]:
    """(wall time in s, peak resident memory in MB) of ``command``, measured by GNU time: a child's
    maximum resident set counts from the process it was forked from, so this big one must not be
    the command's parent."""
    with tempfile.NamedTemporaryFile("r", suffix=".txt") as report:
        done = subprocess.run(["/usr/bin/time", "-f", "%e %M", "-o", report.name, *command],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(command)} failed: {done.stderr[-500:]}")
        wall, peak = report.read().split()[-2:]
    return float(wall), float(peak) / 1024


STREAMING_SECTION = "## Streaming runs"
CAMPAIGN_SECTION = "## Campaigns"


def streaming_section(config, hours: tuple[float, ...]) -> list[str]:
    vsegen = [sys.executable, "-m", "vsegen.harness.cli"]
    lines = [STREAMING_SECTION, "",
             f"{provenance('python -m bench.campaign')}: `vsegen run` and `vsegen score` on a CSV log at 100 Hz "
             "tiled from simulated manoeuvres (c_class), each a fresh process on this 2-core machine; wall time "
             "and peak resident memory (GNU time). The log is read, run and written in chunks of 65,536 "
             "samples, so memory does not grow with the log. Before streaming (issue #34, one hour): kf2dof "
             "6.9 s / 885 MB, switching 5.9 s / 883 MB, ukf 8.0 s / 884 MB, pf_improved 18.4 s / 3.6 GB; "
             "score 6.1 s / 883 MB.", "",
             "| log | MB | estimator | run (s) | run peak (MB) | score (s) | score peak (MB) |",
             "|---|---|---|---|---|---|---|"]
    parts = pieces(config)
    for length in hours:
        path = DATA / f"drive_{length:g}h.csv"
        if not path.exists():
            write_csv(synthetic_log(parts, int(length * 3600 * RATE), seed=100), path)
        for name in RUN_ESTIMATORS:
            estimates = DATA / f"est_{name}_{length:g}h.csv"
            run_wall, run_peak = timed([*vsegen, "run", "--log", str(path), "--estimator", name, "--out",
                                        str(estimates), "--vehicle", str(DEFAULT_VEHICLE)])
            score_wall, score_peak = timed([*vsegen, "score", "--log", str(path), "--est", str(estimates)])
            estimates.unlink()
            lines.append(f"| {length:g} h | {path.stat().st_size / 1e6:.0f} | {name} | {run_wall:.2f} | "
                         f"{run_peak:.0f} | {score_wall:.2f} | {score_peak:.0f} |")
    return lines


def measure(mode: str, folder: Path, count: int) -> dict:
    """One campaign over the first ``count`` logs of ``folder`` (this process, a fresh cache unless
    the caller set one): wall time, runs computed and from the cache, samples, peak memory per
    worker (MB)."""
    from vsegen.harness.campaign.run import Settings, find_logs, run_campaign
    from vsegen.harness.jobs.pool import DaskPool

    config = load_vehicle(DEFAULT_VEHICLE)
    settings = [Settings("c_class", config, "bench")]
    logs = find_logs([str(folder)])[:count]
    scheduler = {"serial": "serial", "local": "local"}.get(mode, mode)
    with DaskPool(scheduler) as pool:
        cpu = sum(pool.on_workers(_cpu_seconds))
        start = time.perf_counter()
        result = run_campaign(logs, CAMPAIGN_ESTIMATORS, settings, None, DATA / "car.dbc", pool)
        wall = time.perf_counter() - start
        cpu = sum(pool.on_workers(_cpu_seconds)) - cpu
        peaks = pool.on_workers(_peak_memory)
    return {"wall": wall, "computed": result.computed, "cached": result.cached, "failed": len(result.failed),
            "samples": sum(row["samples"] for row in result.rows), "workers": len(peaks), "peaks": peaks,
            "cpu": cpu}


def _cpu_seconds() -> float:
    """CPU time (user + system, s) of this process so far, all its threads."""
    times = os.times()
    return times.user + times.system


def _peak_memory() -> float:
    """MB: this process's peak resident set (VmHWM: the high-water mark of its own memory, not the
    maximum resident set, which a child inherits from the process it was forked from)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return float(line.split()[1]) / 1024
    raise RuntimeError("no VmHWM in /proc/self/status")


def _measured(mode: str, folder: Path, count: int, cache: Path) -> dict:
    """:func:`measure` in a fresh process with the cache folder ``cache``."""
    done = subprocess.run([sys.executable, "-m", "bench.campaign", "--measure", mode, "--logs", str(count),
                           "--folder", str(folder)], cwd=REPO, capture_output=True, text=True,
                          env={**os.environ, "VSEGEN_CACHE": str(cache)})
    if done.returncode != 0:
        raise RuntimeError(f"campaign {mode} failed: {done.stderr[-800:]}")
    return json.loads(done.stdout.splitlines()[-1])


def campaign_section(config, count: int, minutes: float) -> list[str]:
    folder = DATA / f"logs_{minutes:g}min"
    database(config, count + 10, minutes, folder)
    cores = os.cpu_count() or 1
    lines = [CAMPAIGN_SECTION, "",
             f"{provenance('python -m bench.campaign')}: {count} synthetic logs of {minutes:g} min at 100 Hz (c_class "
             "manoeuvres tiled in random orders; a third CSV, a third MDF4, a third raw-CAN MDF4 decoded with a "
             f"DBC) x {len(CAMPAIGN_ESTIMATORS)} estimators ({', '.join(CAMPAIGN_ESTIMATORS)}), each log read once "
             f"for all three, on this {cores}-core machine, a fresh cache each time. Throughput counts estimator-"
             "samples (a sample run through one estimator) per second per worker; the workers' CPU time shows "
             "how much of the second core a single process already uses (pyarrow parses with threads); memory "
             "is each worker process's peak resident set (VmHWM).", "",
             "| where | workers | wall (s) | workers' CPU (s) | runs computed | throughput (samples/s per worker) | "
             "peak per worker (MB) |",
             "|---|---|---|---|---|---|---|"]
    scheduler = _start_scheduler()
    try:
        modes = (("serial (one process)", "serial"), ("LocalCluster", "local"),
                 ("scheduler + 2 worker processes", scheduler[0]))
        for label, mode in modes:
            with tempfile.TemporaryDirectory() as cache:
                m = _measured(mode, folder, count, Path(cache))
            if m["failed"]:
                raise RuntimeError(f"campaign {mode}: {m['failed']} log(s) failed")
            rate = m["samples"] / m["wall"] / max(m["workers"], 1)
            lines.append(f"| {label} | {m['workers']} | {m['wall']:.1f} | {m['cpu']:.1f} | {m['computed']} | "
                         f"{rate:,.0f} | {', '.join(f'{p:.0f}' for p in m['peaks'])} |")
        with tempfile.TemporaryDirectory() as cache:
            _measured("local", folder, count, Path(cache))
            again = _measured("local", folder, count + 10, Path(cache))
        lines += ["", f"Adding 10 logs and running the campaign again on the LocalCluster computed "
                      f"{again['computed']} runs and read {again['cached']} from the cache in {again['wall']:.1f} s."]
    finally:
        for process in scheduler[1]:
            process.terminate()
            process.wait(timeout=30)
    return lines


def _start_scheduler() -> tuple[str, list[subprocess.Popen]]:
    """(address, processes) of a Dask scheduler and two single-threaded worker processes."""
    scheduler_file = Path(tempfile.mkdtemp()) / "scheduler.json"
    processes = [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--no-dashboard",
                                   "--scheduler-file", str(scheduler_file)], stderr=subprocess.DEVNULL)]
    for _ in range(300):
        if scheduler_file.exists():
            break
        time.sleep(0.1)
    address = json.loads(scheduler_file.read_text())["address"]
    processes += [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
                                    "--no-dashboard"], stderr=subprocess.DEVNULL) for _ in range(2)]
    time.sleep(3.0)
    return address, processes


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=BENCHMARKS)
    parser.add_argument("--logs", type=int, default=100, help="logs in the campaign (default 100)")
    parser.add_argument("--minutes", type=float, default=10.0, help="minutes per log (default 10)")
    parser.add_argument("--hours", type=float, nargs="*", default=[1.0, 10.0], help="streaming logs' lengths")
    parser.add_argument("--sections", nargs="+", choices=("streaming", "campaigns"), default=["streaming", "campaigns"],
                        help="which sections to measure (default both)")
    parser.add_argument("--measure", help=argparse.SUPPRESS)
    parser.add_argument("--folder", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.measure:
        print(json.dumps(measure(args.measure, args.folder, args.logs)))
        return
    DATA.mkdir(parents=True, exist_ok=True)
    config = load_vehicle(DEFAULT_VEHICLE)
    if "streaming" in args.sections:
        write_section(args.out, streaming_section(config, tuple(args.hours)))
    if "campaigns" in args.sections:
        write_section(args.out, campaign_section(config, args.logs, args.minutes))


if __name__ == "__main__":
    main()
