#!/usr/bin/env bash
# Copies the start of the real Kinect v1 recording
# ../shared/data/real_depth/kinect1_upper_body_close.oni (a person 0.7-1.0 m from
# the sensor, only the upper body in view; 16 frames, 3.2 MB) into
# test/data/real_depth_upper_body.oni, under 2 MB, so that the partial-view
# rostest needs nothing outside the repo. The stock Recorder records the file as
# OniFile plays it, in real time (~0.8 s: 7-9 frames, device timestamps from 0).
#   scripts/make_real_depth_excerpt.sh [SOURCE.oni] [OUT.oni]
# Needs the built workspace sourced (source WS/devel/setup.bash).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
src=${1:-$here/../shared/data/real_depth/kinect1_upper_body_close.oni}
out=${2:-$here/test/data/real_depth_upper_body.oni}
[ -f "$src" ] || { echo "make_real_depth_excerpt.sh: no recording $src" >&2; exit 1; }
bin=$(catkin_find --first-only --libexec hri_sync record_oni 2>/dev/null || true)
info=$(catkin_find --first-only --libexec hri_sync oni_info 2>/dev/null || true)
if [ -z "$bin" ] || [ -z "$info" ]; then
  echo "make_real_depth_excerpt.sh: record_oni not built; run 'make build' and source WS/devel/setup.bash" >&2
  exit 1
fi
for seconds in 0.8 0.7 0.6 0.5; do
  rm -f "$out"
  "$bin" "$src" "$out" "$seconds"
  size=$(stat -c %s "$out")
  frames=$("$info" "$out" | sed 's/.*"frames": \([0-9]*\).*/\1/')
  if [ "$size" -lt 2000000 ] && [ "$frames" -ge 5 ]; then
    echo "$out: $frames frames, $size bytes"
    exit 0
  fi
  echo "$seconds s gave $frames frames, $size bytes: trying shorter" >&2
done
echo "make_real_depth_excerpt.sh: no excerpt of 5+ frames under 2 MB" >&2
exit 1
