#!/usr/bin/env bash
# Runs a command with the private OpenNI2 folder of the build (stock drivers plus
# the virtual Kinect) on LD_LIBRARY_PATH, e.g.
#   scripts/openni2_env.sh NiViewer2 "virtual://$PWD/data/motion/cmu_60_01_salsa.track"
# Needs the built workspace sourced (source WS/devel/setup.bash).
set -euo pipefail
bin=$(catkin_find --first-only --libexec hri_sync record_oni 2>/dev/null || true)
if [ -z "$bin" ]; then
  echo "openni2_env.sh: hri_sync not built; run 'make build' and source WS/devel/setup.bash" >&2
  exit 1
fi
export LD_LIBRARY_PATH="$(dirname "$bin")/openni2${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
exec "$@"
