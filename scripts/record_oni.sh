#!/usr/bin/env bash
# Records a depth .oni file from the virtual Kinect playing a motion, then checks
# that the stock OniFile driver plays it back.
#   scripts/record_oni.sh MOTION.track OUT.oni SECONDS [OPTIONS]
# OPTIONS are virtual Kinect URI keys joined by '&' (see docs/tracker.md), e.g.
# "res=640x480&background=1&start=4". The recorder runs in real time.
# Needs the built workspace sourced (source WS/devel/setup.bash).
set -euo pipefail
if [ $# -lt 3 ]; then
  sed -n '2,7p' "$0" | sed 's/^# \{0,1\}//'
  exit 2
fi
motion=$(readlink -f "$1"); out=$2; seconds=$3; opts=${4:-}
[ -f "$motion" ] || { echo "record_oni.sh: no motion file $1" >&2; exit 1; }
bin=$(catkin_find --first-only --libexec hri_sync record_oni 2>/dev/null || true)
info=$(catkin_find --first-only --libexec hri_sync oni_info 2>/dev/null || true)
if [ -z "$bin" ] || [ -z "$info" ]; then
  echo "record_oni.sh: record_oni not built; run 'make build' and source WS/devel/setup.bash" >&2
  exit 1
fi
uri="virtual://$motion"
[ -n "$opts" ] && uri="$uri?$opts"
"$bin" "$uri" "$out" "$seconds"
"$info" "$out"
