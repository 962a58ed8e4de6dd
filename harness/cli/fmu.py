"""`vsegen fmu`: an estimator's generated C as a co-simulation FMU (FMI 3.0 or 2.0) for SIL."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from vsegen.codegen.fmu import FMI_VERSIONS
from vsegen.harness.cli.common import (
    PARAMS_OPTION,
    REAL_OPTION,
    VEHICLE_OPTION,
    chosen_estimators,
    console,
    display,
    stale_kit,
    user_errors,
    vehicle_config,
)


@click.command()
@VEHICLE_OPTION
@click.option("--estimator", "name", required=True, help="Estimator name.")
@REAL_OPTION
@PARAMS_OPTION
@click.option("--fmi", type=click.Choice([str(v) for v in reversed(FMI_VERSIONS)]), default=str(max(FMI_VERSIONS)),
              show_default=True, help="FMI version.")
@click.option("--out", type=click.Path(path_type=Path), default=None,
              help="The FMU file to write. Default: vse_<estimator>.fmu in the current folder.")
@user_errors
def fmu(vehicle: Path | None, name: str, real: str | None, params: str | None, fmi: str, out: Path | None) -> None:
    """Package an estimator's generated C as a co-simulation FMU for this platform (x86_64-linux),
    with its sources: inputs and outputs with units, the sample time as the fixed step, and (with
    --params calibratable) the calibration as tunable parameters within their bounds."""
    from vsegen.harness.fmu.package import build_fmu

    config = vehicle_config(vehicle)
    (name,) = chosen_estimators(config, (name,))
    real = real or config.codegen["real"]
    params = params or config.codegen["params"]
    if stale_kit(config, name, real, params, "fmu", missing_ok=True):
        sys.exit(1)
    out = out or Path(f"vse_{name}.fmu")
    if out.suffix != ".fmu":
        raise click.UsageError(f"--out {out}: expected a file name ending in .fmu")
    written = build_fmu(config, name, real, params, int(fmi), out)
    console.print(f"wrote {display(written.path)}: FMI {fmi}.0 co-simulation, {name} for vehicle {config.name} "
                  f"({real}, {params} parameters), step {config.sample_time} s, binary {written.binary}, "
                  f"{written.sources} C sources")
