#!/usr/bin/env bash
# New car in four commands (README, "New car in four commands"), on simulated logs of the second
# truth car: the logs stand in for a test drive (ordinary driving, no ground truth) and a test-track
# day (manoeuvres with an optical beta reference). Usage: bash examples/new_car.sh [WORK_DIR]
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
work=${1:-new_car}
mkdir -p "$work/vehicles" "$work/drive" "$work/track" "$work/holdout"
cd "$work"
truth="$repo/vehicles/rwd_saloon.toml"

# The engineer's starting file: the C-class file with this car's mass, geometry and I_z typed in.
python3 - "$repo/vehicles/c_class.toml" vehicles/car.toml <<'PY'
import sys
from pathlib import Path
from vsegen.harness.project.vehicles import with_settings
text = with_settings(Path(sys.argv[1]).read_text(), "vehicle", mass=1780.0, yaw_inertia=3050.0,
                     cg_to_front_axle=1.30, cg_to_rear_axle=1.65, wheelbase=2.95, wheel_radius=0.335,
                     track_width=1.60, cg_height=0.56)
Path(sys.argv[2]).write_text(text)
PY

# Logs (simulated here; on a real car these come from the logger).
vsegen simulate step_steer --vehicle "$truth" --set delta=0.02 --set duration=8 --no-truth --out drive/step_small.csv
vsegen simulate step_steer --vehicle "$truth" --set delta=0.04 --set speed_kmh=70 --set duration=8 --no-truth --out drive/step_large.csv
vsegen simulate sine_steer --vehicle "$truth" --no-truth --out drive/sine.csv
vsegen simulate dlc --vehicle "$truth" --set speed_kmh=60 --no-truth --out drive/lane_change.csv
vsegen simulate hil_sine --vehicle "$truth" --no-truth --out drive/weave.csv
vsegen simulate dlc --vehicle "$truth" --out track/dlc.csv
vsegen simulate step_steer --vehicle "$truth" --out track/step.csv
vsegen simulate sine_steer --vehicle "$truth" --out track/sine.csv
vsegen simulate fishhook --vehicle "$truth" --out track/fishhook.csv
vsegen simulate dlc --vehicle "$truth" --set mu=0.5 --out track/dlc_low_friction.csv
vsegen simulate continuous_dlc --vehicle "$truth" --set speed_kmh=80 --out holdout/continuous_dlc.csv

# 1. identify  2. tune  3. generate  4. verify: the work folder is a vsegen project (it has vehicles/), and the
# identified and tuned car stays vehicles/car.toml, so `vsegen generate --check` stays green
vsegen identify --vehicle vehicles/car.toml --out vehicles/car.toml --report identify.md \
  --log drive/step_small.csv --log drive/step_large.csv --log drive/sine.csv --log drive/lane_change.csv --log drive/weave.csv
vsegen tune --estimator switching --vehicle vehicles/car.toml --out vehicles/car.toml \
  --log track/dlc.csv --log track/step.csv --log track/sine.csv --log track/fishhook.csv --log track/dlc_low_friction.csv \
  --holdout holdout/continuous_dlc.csv
vsegen generate --estimator switching
vsegen verify --estimator switching
vsegen generate --check --estimator switching
