#!/bin/bash
# The real recordings the fusion's learned error model is fitted on
# besides the development clip (bench/fit_error_model.py --also): six
# Kinect v1 sequences of the PRECOG dataset (people punching and kicking,
# facing the sensor), none of those docs/fusion.md measures the fusion on,
# converted by scripts/real_skeleton_motion.py into data/motion/real/
# (not data/motion/, whose clips scripts/campaign.py dances).
#
#   scripts/make_fit_motions.sh [REAL_SKELETON_DIR]
#
# REAL_SKELETON_DIR holds kinect1_precog/ (default ../shared/data/real_skeleton).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
SRC=${1:-$ROOT/../shared/data/real_skeleton}
PY=$ROOT/.venv/bin/python
[ -x "$PY" ] || PY=/usr/bin/python3
for seq in Seq1_1 Seq2_2 Seq3_3 Seq4_4 Seq5_5 Seq6_6; do
  "$PY" "$ROOT/scripts/real_skeleton_motion.py" \
    "$SRC/kinect1_precog/$seq.csv" --out "$ROOT/data/motion/real/precog_$seq.npz"
done
