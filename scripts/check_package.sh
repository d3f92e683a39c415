#!/bin/bash
# Package checks (make check; needs a built .ws):
#   rosdep   every key of package.xml resolves and is installed
#            (rosdep check --from-paths . --ignore-src);
#   lint     catkin_lint -W1 reports no error;
#   launch   roslaunch-check passes on every launch file, and every arg
#            a user can set (no value=) has a doc;
#   mypy     the core packages (mypy.ini: wire, clock, ..., fusion) type-check.
# Without a rosdep database (no `rosdep update`, or no network) rosdep and
# catkin_lint use an offline one in .ws/rosdep: Debian's own list of the
# ROS keys plus scripts/rosdep/system-keys.yaml for the system keys.
set -u
ROOT=$(cd "$(dirname "$0")/.." && pwd)
WS=$ROOT/.ws
status=0
fail() { echo "check_package: FAIL: $*"; status=1; }

set +u; source "$WS/devel/setup.bash"; set -u

if ! rosdep resolve roscpp >/dev/null 2>&1; then
  db=$WS/rosdep
  mkdir -p "$db/sources.list.d"
  printf 'type: index\nversion: 4\ndistributions: {}\n' > "$db/index-v4.yaml"
  printf 'yaml file:///usr/share/python3-rosdep2/debian.yaml debian\nyaml file://%s\n' \
    "$ROOT/scripts/rosdep/system-keys.yaml" > "$db/sources.list.d/10-offline.list"
  export ROSDEP_SOURCE_PATH=$db/sources.list.d ROS_HOME=$db/home \
    ROSDISTRO_INDEX_URL=file://$db/index-v4.yaml
  rosdep update >"$db/update.log" 2>&1 || fail "rosdep update (see $db/update.log)"
  echo "check_package: rosdep: offline database (Debian's ROS keys + scripts/rosdep/system-keys.yaml)"
fi

echo "check_package: rosdep check --from-paths . --ignore-src"
rosdep check --from-paths "$ROOT" --ignore-src || fail "rosdep check"

echo "check_package: catkin_lint -W1"
lint=$(catkin_lint -W1 "$ROOT" 2>&1)
echo "$lint" | grep -E 'error|warning' | grep -v 'is executable but not installed'
echo "$lint" | grep -q ': error: ' && fail "catkin_lint reports errors"

out=$WS/test_results/hri_sync
mkdir -p "$out"
# One process checks the folder (each file's error names the file).
if ! log=$(/usr/bin/python3 "$(rospack find roslaunch)/scripts/roslaunch-check" -i -o "$out/roslaunch-check_launch.xml" "$ROOT/launch" 2>&1) \
    || ! grep -q 'failures="0"' "$out/roslaunch-check_launch.xml"; then
  echo "$log" | tail -20
  fail "roslaunch-check launch/"
fi
echo "check_package: roslaunch-check on launch/*.launch done"

echo "check_package: every settable launch arg has a doc"
/usr/bin/python3 - "$ROOT"/launch/*.launch <<'PY' || fail "launch args without a doc"
import sys
import xml.etree.ElementTree as ET
missing = ['%s: %s' % (f.rsplit('/', 1)[-1], a.get('name'))
           for f in sys.argv[1:] for a in ET.parse(f).getroot().iter('arg')
           if 'value' not in a.attrib and not a.get('doc')]
if missing:
    print('\n'.join(missing))
sys.exit(1 if missing else 0)
PY

echo "check_package: mypy (mypy.ini: the core packages)"
(cd "$ROOT" && mypy) || fail "mypy"

[ $status = 0 ] && echo "check_package: all passed"
exit $status
