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

# Priors around the nominal model (docs/real-data.md, "Priors"): crossval chooses the size
# by held-out error (--prior auto) and reports the largest change of a link parameter from
# nominal with and without it; also the default size (5 mm, 1°), and calibrate with the
# prior (model-prior.json records it).
echo "== priors (crossval --prior auto, then the default 5 mm, 1°):"
for NAME in figaroh-talos-arm figaroh-ur10e robotkinecal-fr3; do
    D=$OUT/$NAME
    CSV=$D/data.csv
    if [ -f "$D/observed.csv" ]; then CSV=$D/observed.csv; fi
    for P in auto 5,1; do
        TAG=${P/5,1/default}
        "$K" crossval "$CSV" --robot "$D/robot.toml" --effects base_frame,tool_frame \
            --init-frames --folds 5 --seed 1 --prior "$P" --json "$D/crossval-prior-$TAG.json" \
            > "$D/crossval-prior-$TAG.txt"
        echo "   $NAME --prior $P:"
        grep -E "^Prior|^  prior|^Largest change|held-out RMS" "$D/crossval-prior-$TAG.txt" |
            sed 's/^/     /'
    done
    SP=$(json_number sigma_pos_mm "$D/crossval.json")
    SR=$(json_number sigma_rot_deg "$D/crossval.json")
    if [ "$SR" = "null" ]; then SR=1; fi
    "$K" calibrate "$CSV" --robot "$D/robot.toml" --effects base_frame,tool_frame \
        --init-frames --allow-data-deficiency --sigma-pos-mm "$SP" --sigma-rot-deg "$SR" \
        --prior --out "$D/model-prior.json" > "$D/calibrate-prior.txt" 2>&1
done

# TIAGo needs the user's URDF (CC BY-NC-ND, not shipped): with $TIAGO_URDF set, import it;
# otherwise record the refusal, which says where to get it.
if [ -n "${TIAGO_URDF:-}" ]; then
    "$K" import-dataset tiago "$DATA/figaroh-tiago-mocap" --urdf "$TIAGO_URDF" \
        --out "$OUT/tiago.csv" --robot-out "$OUT/tiago.toml" > "$OUT/tiago.txt"
    echo "== tiago -> $OUT/tiago.txt"
else
    "$K" import-dataset tiago "$DATA/figaroh-tiago-mocap" --out "$OUT/unused.csv" \
        2>> "$OUT/refused.txt" && echo "unexpected: tiago imported without a URDF" >&2 || true
    echo "== tiago needs TIAGO_URDF=tiago.urdf: $OUT/refused.txt"
fi

# Hilti (CC BY-NC-SA: read from the data folder, nothing copied): every floor a session,
# accelerometer tilts as sensor joints; the held-out study of docs/real-data.md (trained
# on flat, every other floor with a new base frame only; the variants of the tilt model;
# leave one session out).
D=$OUT/hilti
mkdir -p "$D"
"$K" import-dataset hilti "$DATA/hilti-jaibot-stationing" --out "$D/data.csv" \
    --robot-out "$D/robot.toml" --study > "$D/study.txt"
echo "== hilti -> $D/study.txt"
sed -n '/^Hilti study/,$p' "$D/study.txt" | sed 's/^/     /'
# The diagnosis with the total station's stated noise (each floor a session, registered in
# its own base frame): where the gap lies by session, height and arm solution space, which
# effect, and thermal confounded with the sessions.
"$K" diagnose "$D/data.csv" --robot "$D/robot.toml" --sigma-pos-mm 0.75 \
    --json "$D/diagnose.json" --report "$D/diagnose.txt" --out "$D/diagnose-model.json" \
    > /dev/null
grep -E "^VERDICT|^  why:|^  confounded with:|^HOW FAR|^  thermal:|^  what would separate" \
    "$D/diagnose.txt" | sed 's/^/   /'

# MUKCa (no instrument): every robot held out by location. For each location L: calibrate
# on the other locations (their targets, sessions and 50 mm distances), validate on L
# (consistency: scatter of the predicted ball centre per socket; the 50 mm distance).
echo "== mukca, leave one location out (validate on the held-out location; NOM = URDF):"
for ID in panda_1 panda_1_with_sensor panda_2 panda_2_clean panda_3 panda_3_bis panda_4 \
    panda_4_clean panda_6 panda_7 kuka_14 dinova_1 dinova_2; do
    D=$OUT/mukca/$ID
    mkdir -p "$D"
    "$K" import-dataset mukca "$DATA/mukca" --robot-id "$ID" --out "$D/data.csv" \
        --robot-out "$D/robot.toml" --constraints-out "$D/constraints.toml" > "$D/import.txt"
    for L in $(grep -v '^#' "$D/data.csv" | tail -n +2 | cut -d, -f2 | sort -u); do
        for PART in train test; do
            grep -v '^#' "$D/data.csv" | awk -F, -v L="$L" -v P="$PART" \
                'NR == 1 || (P == "test" ? $2 == L : $2 != L)' > "$D/$L-$PART.csv"
            cut -d, -f2 "$D/$L-$PART.csv" | tail -n +2 | sort -u | awk '{
                printf "[[distance]]\nbetween = [\"%s/s0\", \"%s/s1\"]\nm = 0.05\n\n", $1, $1 }' \
                > "$D/$L-$PART-constraints.toml"
        done
        "$K" calibrate "$D/$L-train.csv" --robot "$D/robot.toml" \
            --constraints "$D/$L-train-constraints.toml" --allow-out-of-limits \
            --out "$D/$L-model.json" > "$D/$L-calibrate.txt" 2>&1
        "$K" validate "$D/$L-model.json" "$D/$L-test.csv" --allow-out-of-limits \
            --constraints "$D/$L-test-constraints.toml" > "$D/$L-validate.txt" 2>&1
        echo "   $ID held out $L: $(grep -E '^  (NOM|OLS) ' "$D/$L-validate.txt" | head -2 |
            awk '{printf "%s mean RMS %s mm, |dist err| %s mm; ", $1, $2, $4}')"
    done
done

# The same held-out placements scored by crossval's own contact scoring (panda_2_clean).
D=$OUT/mukca/panda_2_clean
"$K" crossval "$D/data.csv" --robot "$D/robot.toml" --constraints "$D/constraints.toml" \
    --group-by session --folds 8 --allow-out-of-limits > "$D/crossval.txt" 2>&1
echo "== mukca panda_2_clean, crossval --group-by session --folds 8:"
grep -E "^  (nominal|calibrated) " "$D/crossval.txt" | sed 's/^/   /'

# A real diagnosis (contact data): every candidate the data can express, held out by
# location; without a floor, then with σ = 0.17 mm (the fixture's upper bound, from the
# Panda's in-sample scatter).
echo "== mukca diagnosis (leave one location out):"
for ID in panda_2_clean panda_3 kuka_14 dinova_1 dinova_2; do
    D=$OUT/mukca/$ID
    "$K" diagnose "$D/data.csv" --robot "$D/robot.toml" --constraints "$D/constraints.toml" \
        --allow-out-of-limits --json "$D/diagnose.json" --out "$D/diagnose-unused.json" \
        > /dev/null 2>&1
    "$K" diagnose "$D/data.csv" --robot "$D/robot.toml" --constraints "$D/constraints.toml" \
        --allow-out-of-limits --sigma-pos-mm 0.17 --json "$D/diagnose-floor.json" \
        --out "$D/diagnose-unused.json" > /dev/null 2>&1
    echo "   $ID: $(grep -h '^VERDICT' "$D/diagnose.txt" "$D/diagnose-floor.txt" | tr '\n' ' ')"
done

# MATE: the 30 plane contacts (one coordinate each, q_1 negated by the importer), 5-fold
# held-out rows, mate.urdf's own base frame.
D=$OUT/figaroh-mate-planes
mkdir -p "$D"
"$K" import-dataset figaroh-mate-planes "$DATA/figaroh-mate-planes" --out "$D/data.csv" \
    --robot-out "$D/robot.toml" > "$D/import.txt"
grep -v 'pose/' "$D/data.csv" > "$D/planes.csv"
"$K" crossval "$D/planes.csv" --robot "$D/robot.toml" --folds 5 --seed 1 \
    --allow-out-of-limits --json "$D/crossval.json" > "$D/crossval.txt" 2>&1
"$K" crossval "$D/planes.csv" --robot "$D/robot.toml" --geometry theta0 \
    --folds 5 --seed 1 --allow-out-of-limits > "$D/crossval-theta0.txt" 2>&1
"$K" crossval "$D/planes.csv" --robot "$D/robot.toml" --effects base_frame --folds 5 --seed 1 \
    --allow-out-of-limits > "$D/crossval-base.txt" 2>&1
echo "== figaroh-mate-planes (plane contacts, held-out rows; geometry, θ0 only, geometry+base):"
grep -h "held-out RMS" "$D/crossval.txt" "$D/crossval-theta0.txt" "$D/crossval-base.txt" | sed 's/^/   /'
