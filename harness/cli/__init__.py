"""The ``vsegen`` command line: one module per stage of the flow (project, simulate, identify, tune,
generate, verify, run, score, campaign, target, fmu), each registering its commands on :func:`main`.

User mistakes (a bad vehicle file, a bad log, an unknown name) end in one line on stderr and exit
status 2; a failed check ends with status 1.
"""

from __future__ import annotations

import os
import sys

import click

from vsegen.harness.cli import campaign, fmu, generate, identify, project, run, score, simulate, target, tune, verify


@click.group()
@click.version_option(package_name="vsegen")
def main() -> None:
    """vsegen: vehicle state estimators, from CasADi to standalone C, proven equal to NumPy."""


for command in (project.init, project.list_, project.docs, simulate.simulate, identify.identify, tune.tune,
                generate.generate, verify.verify, run.run, score.score, score.plot, campaign.campaign,
                target.pil_command, target.size, target.misra, target.a2l, fmu.fmu):
    main.add_command(command)


def entry() -> None:
    """The console entry point: run :func:`main`, then leave without Python's final teardown.

    A command's work is done (files closed, clusters shut down, output flushed below) when ``main``
    returns; in the teardown, a library's native worker thread still alive aborts the process now
    and then (SIGABRT, "terminate called without an active exception"; seen about once in 100
    `vsegen score` runs; apache/arrow#34314), which would turn a finished command into a failure."""
    try:
        main()
        code: int | str | None = 0
    except SystemExit as done:
        code = done.code
    if isinstance(code, str):
        print(code, file=sys.stderr)
        code = 1
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code or 0)
