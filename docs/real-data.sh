#!/usr/bin/env bash
# Reruns the real-data study of docs/real-data.md: every public data set with an adapter is
# imported as published (camera poses also re-expressed at the point the camera looks at),
# cross-validated (nominal vs calibrated on held-out poses, noise
# floor, outliers), calibrated on all poses (identifiability report, parameters) and
# diagnosed. Numbers (text and JSON) and SVG figures go to OUT, one folder per set.
#
#   docs/real-data.sh [OUT]          (default OUT: <target dir>/real-data)
#
# The data sets are read from ../shared/realdata next to the repository, or from
# $KINCAL_REALDATA. Nothing is written into the repository or the data folder.
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
DATA=${KINCAL_REALDATA:-$ROOT/../shared/realdata}
TARGET=${CARGO_TARGET_DIR:-$ROOT/target}
OUT=${1:-$TARGET/real-data}
if [ ! -d "$DATA" ]; then
    echo "real-data.sh: no data folder at $DATA (set KINCAL_REALDATA)" >&2
    exit 2
fi

cargo build --release --quiet --manifest-path "$ROOT/Cargo.toml" -p kincal-cli
K=$TARGET/release/kincal
mkdir -p "$OUT"

# A number from crossval's JSON: the first "KEY": value (noise_floor's sigma_*).
json_number() {
    grep -m1 "\"$1\"" "$2" | sed -e 's/.*": *//' -e 's/,$//'
}

"$K" import-dataset --list > "$OUT/datasets.txt"
echo "== data sets: $OUT/datasets.txt"

for NAME in figaroh-ur10e robotkinecal-fr3 figaroh-talos-arm ical-2axis-positioner; do
    D=$OUT/$NAME
    mkdir -p "$D"
    echo "== $NAME -> $D"
    "$K" import-dataset "$NAME" "$DATA/$NAME" --out "$D/data.csv" --robot-out "$D/robot.toml" \
        > "$D/import.txt"
    CSV=$D/data.csv
    case $NAME in
    figaroh-ur10e | robotkinecal-fr3)
        # Eye-in-hand cameras: the held-out residual of the poses as published (camera
        # centre), then every step on the poses re-expressed where the camera looks.
        "$K" crossval "$D/data.csv" --robot "$D/robot.toml" --effects base_frame,tool_frame \
            --init-frames --folds 5 --seed 1 --json "$D/crossval-camera.json" \
            --plot "$D/crossval-camera.svg" > "$D/crossval-camera.txt"
        grep -E "held-out RMS" "$D/crossval-camera.txt" | sed 's/^/   camera centre: /'
        "$K" observed-point "$D/data.csv" --out "$D/observed.csv" > "$D/observed-point.txt"
        sed 's/^/   /' "$D/observed-point.txt"
        CSV=$D/observed.csv
        ;;
    esac
    # Held-out residuals, noise floor, outliers; the robot with the calibrated frames.
    "$K" crossval "$CSV" --robot "$D/robot.toml" --effects base_frame,tool_frame \
        --init-frames --folds 5 --seed 1 --json "$D/crossval.json" --plot "$D/crossval.svg" \
        --robot-out "$D/robot-frames.toml" > "$D/crossval.txt"
    SP=$(json_number sigma_pos_mm "$D/crossval.json")
    SR=$(json_number sigma_rot_deg "$D/crossval.json")
    if [ "$SR" = "null" ]; then SR=1; fi # position-only data: no rotation rows
    # Calibration on all poses with the same weights: parameters, identifiability.
    "$K" calibrate "$CSV" --robot "$D/robot.toml" --effects base_frame,tool_frame \
        --init-frames --allow-data-deficiency --sigma-pos-mm "$SP" --sigma-rot-deg "$SR" \
        --out "$D/model.json" > "$D/calibrate.txt" 2>&1
    # Sim-to-real diagnosis from the calibrated frames; noise floor: crossval's estimate.
    "$K" diagnose "$CSV" --robot "$D/robot-frames.toml" --sigma-pos-mm "$SP" \
        --sigma-rot-deg "$SR" --json "$D/diagnose.json" --report "$D/diagnose.txt" \
        --out "$D/diagnose-model.json" > /dev/null
    grep -E "held-out RMS|Noise floor|outlier" "$D/crossval.txt" | sed 's/^/   /'
    grep -E "^VERDICT" "$D/diagnose.txt" | sed 's/^/   /'
done

# UR10e has 23 poses: leave-one-out as well, and the joint offsets alone (at the observed
# point).
D=$OUT/figaroh-ur10e
"$K" crossval "$D/observed.csv" --robot "$D/robot.toml" --effects base_frame,tool_frame \
    --init-frames --folds 23 --json "$D/crossval-loo.json" > "$D/crossval-loo.txt"
"$K" crossval "$D/observed.csv" --robot "$D/robot.toml" --effects base_frame,tool_frame \
    --init-frames --folds 5 --seed 1 --geometry theta0 --json "$D/crossval-theta0.json" \
    > "$D/crossval-theta0.txt"
echo "== figaroh-ur10e leave-one-out and joint offsets only:"
grep -h "held-out RMS" "$D/crossval-loo.txt" "$D/crossval-theta0.txt" | sed 's/^/   /'

# Sets that are not usable as they are: the refusal and its reason.
for NAME in figaroh-tiago-mocap hilti-jaibot-stationing; do
    "$K" import-dataset "$NAME" "$DATA/$NAME" --out "$OUT/unused.csv" 2>> "$OUT/refused.txt" \
        && echo "unexpected: $NAME imported" >&2 || true
done
echo "== refused sets: $OUT/refused.txt"
