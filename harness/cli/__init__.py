"""The ``vsegen`` command line: one module per stage of the flow (project, simulate, identify, tune,
generate, verify, run, score, campaign, target), each registering its commands on :func:`main`.

User mistakes (a bad vehicle file, a bad log, an unknown name) end in one line on stderr and exit
status 2; a failed check ends with status 1.
"""

from __future__ import annotations

import click

from vsegen.harness.cli import campaign, generate, identify, project, run, score, simulate, target, tune, verify


@click.group()
@click.version_option(package_name="vsegen")
def main() -> None:
    """vsegen: vehicle state estimators, from CasADi to standalone C, proven equal to NumPy."""


for command in (project.init, project.list_, project.docs, simulate.simulate, identify.identify, tune.tune,
                generate.generate, verify.verify, run.run, score.score, score.plot, campaign.campaign,
                target.pil_command, target.size, target.misra, target.a2l):
    main.add_command(command)
