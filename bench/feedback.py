"""python -m bench.feedback: how long a developer waits. Times the README's main job
(``vsegen generate && vsegen verify`` on the default vehicle) with an empty cache (cold: every log
simulated, every library compiled) and again with the cache filled (warm), and with ``--suites``
the default test run (``pytest -q``) and the long one (``pytest -q -m slow``), each from an empty
cache as on a fresh CI machine. Wall-clock seconds on this machine (the quantity a developer waits
for; noisy on shared machines, so the load average before each run is recorded). Writes the
"Feedback times" section of docs/benchmarks.md and prints it.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench import BENCHMARKS, REPO
from bench.document import provenance, write_section
from vsegen.harness.jobs.pool import worker_count

SECTION = "## Feedback times"
MAIN_JOB = "vsegen generate && vsegen verify"


def timed(command: str, cache: Path) -> tuple[float, float, str]:
    """(wall seconds, 1-minute load average before, last output line) of a shell ``command``
    run in the repository with ``VSEGEN_CACHE=cache``; raises if it fails."""
    load = os.getloadavg()[0]
    start = time.monotonic()
    result = subprocess.run(command, shell=True, cwd=REPO, capture_output=True, text=True,
                            env={**os.environ, "VSEGEN_CACHE": str(cache)})
    seconds = time.monotonic() - start
    if result.returncode != 0:
        raise SystemExit(f"bench.feedback: '{command}' failed:\n{result.stdout[-2000:]}{result.stderr[-2000:]}")
    last = (result.stdout.strip().splitlines() or [""])[-1]
    return seconds, load, last


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--suites", action="store_true", help="also time the test suites")
    parser.add_argument("--out", type=Path, default=BENCHMARKS)
    args = parser.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory(prefix="vsegen-feedback-") as tmp:
        cache = Path(tmp) / "cache"
        rows.append(("`" + MAIN_JOB + "`", "cold (empty cache)", *timed(MAIN_JOB, cache)))
        rows.append(("`" + MAIN_JOB + "`", "warm (cache filled)", *timed(MAIN_JOB, cache)))
    if args.suites:
        for command in (f"{sys.executable} -m pytest -q -p no:cacheprovider",
                        f"{sys.executable} -m pytest -q -m slow -p no:cacheprovider"):
            with tempfile.TemporaryDirectory(prefix="vsegen-feedback-") as tmp:
                shown = "`python3 " + command.split(" ", 1)[1].replace(" -p no:cacheprovider", "") + "`"
                rows.append((shown, "empty cache", *timed(command, Path(tmp) / "cache")))
    body = [SECTION, "",
            f"{provenance('python -m bench.feedback' + (' --suites' if args.suites else ''))}: wall-clock "
            f"seconds on this {os.cpu_count()}-core machine, {worker_count()} worker processes; the "
            "load average is the machine's 1-minute load just before the run (0 = unloaded).", "",
            "| command | cache | seconds | load before | last line |", "|---|---|---|---|---|"]
    body += [f"| {command} | {cache} | {seconds:.0f} | {load:.1f} | {last} |"
             for command, cache, seconds, load, last in rows]
    write_section(args.out, body)


if __name__ == "__main__":
    main()
