#!/bin/bash
# make test-install: `make install` of make build's tree (nothing is
# compiled twice) staged with DESTDIR into a fresh temporary folder, as a
# packager stages it: outside the package folder, where rosrun would find
# a second copy of every node, and fresh, so a file only an earlier install
# left cannot hide a missing install rule.  Then, from that install space
# alone (a clean environment whose first python3 on PATH is a fake that
# fails):
#   - every installed script's shebang is the ROS Python's;
#   - dance_off.launch runs one round with a replay client under
#     libfaketime (skewed_client) and a skeleton_tracker client on a
#     virtual Kinect, DJ Rob on kobuki_sim and the music, the site frames
#     (static_frame), recording a bag; preflight gives a verdict;
#     rviz.launch's skeleton_markers publishes markers;
#   - verify_decisions recomputes that bag and report writes its HTML and
#     MCAP (with the install's rosbags and mcap venv);
#   - system.launch runs a round (synthetic_sensor);
#   - the C++ tools record_oni, oni_info and tracker_eval run;
#   - no node died (roslaunch's "process has died") in any of it.
# Exit 0 when all of it passed. KEEP=1 keeps the install and its logs.
set -u
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
TMP=$(mktemp -d /tmp/hri_sync_install.XXXXXX)
BUILD=$ROOT/.ws/build
status=0
say() { echo "install_space: $*"; }
fail() { say "FAIL: $*"; status=1; }
cleanup() {
  [ -n "${MASTER_PID:-}" ] && kill "$MASTER_PID" 2>/dev/null && wait "$MASTER_PID" 2>/dev/null
  if [ "${KEEP:-0}" = 1 ]; then say "kept $TMP"; else rm -rf "$TMP"; fi
}
trap cleanup EXIT
free_port() {
  /usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}

mkdir -p "$TMP/badbin"
[ -f "$BUILD/CMakeCache.txt" ] || { fail "no build in $BUILD: run make build first"; exit 1; }
prefix=$(sed -n 's/^CMAKE_INSTALL_PREFIX:PATH=//p' "$BUILD/CMakeCache.txt")
INSTALL=$TMP/root$prefix
say "make install of $BUILD into $INSTALL (DESTDIR; log: $TMP/build.log)"
if ! DESTDIR=$TMP/root cmake --build "$BUILD" --target install > "$TMP/build.log" 2>&1; then
  tail -30 "$TMP/build.log"
  fail "make install (DESTDIR=$TMP/root)"
  exit 1
fi

# A python3 that is not the ROS one comes first on PATH.
printf '#!/bin/sh\necho "fake python3 ran: $*" >&2\nexit 97\n' > "$TMP/badbin/python3"
chmod +x "$TMP/badbin/python3"
PORT=$(free_port)
CLEAN_ENV=(env -i HOME="$TMP" PATH="$TMP/badbin:/usr/local/bin:/usr/bin:/bin"
  ROS_MASTER_URI="http://localhost:$PORT" ROS_HOME="$TMP/ros"
  ROS_LOG_DIR="$TMP/ros/log")
run() {   # run CMD in a clean environment with only the install space
  "${CLEAN_ENV[@]}" bash -c "source '$INSTALL/setup.bash' && $1"
}
spawn() {   # as run, in the background: `spawn "exec CMD" &`, $! is CMD's pid
  exec "${CLEAN_ENV[@]}" bash -c "source '$INSTALL/setup.bash' && $1"
}

share=$(run 'rospack find hri_sync')
[ "$share" = "$INSTALL/share/hri_sync" ] \
  || fail "rospack find hri_sync gives '$share', not the install space"

for f in "$INSTALL"/lib/hri_sync/*; do
  [ -f "$f" ] || continue
  if [ "$(head -c 2 "$f")" = '#!' ]; then
    line=$(head -n 1 "$f")
    [ "$line" = '#!/usr/bin/python3' ] \
      || fail "$(basename "$f"): shebang '$line'"
  fi
done
say "shebangs checked"

spawn "exec roscore -p $PORT" > "$TMP/roscore.log" 2>&1 &
MASTER_PID=$!
run 'until rostopic list >/dev/null 2>&1; do sleep 0.2; done'

say "dance_off.launch: left under faketime, right on a virtual Kinect, preflight, rviz markers"
bag=$TMP/round.bag
spawn "exec roslaunch --wait hri_sync rviz.launch rviz:=false" > "$TMP/rviz.log" 2>&1 &
RVIZ_PID=$!
spawn "exec rostopic echo -n 1 /skeleton_markers" > "$TMP/markers.log" 2>&1 &
ECHO_PID=$!
if ! run "roslaunch --wait hri_sync dance_off.launch dur:=3 rounds:=1 \
      left_clock:='+1.2s x1.0002' right_sensor:=tracker right_motion:=cmu_61_01_salsa \
      preflight:=true ntp_port:=$(free_port) bag:=$bag left_seed:=4 right_seed:=21" > "$TMP/dance_off.log" 2>&1; then
  tail -30 "$TMP/dance_off.log"
  fail "dance_off.launch"
fi
# preflight ran if it gave a verdict; which one depends on the load (a
# starved tracker publishes slowly at first); test/unit/test_preflight.py
# and the rostest preflight_nogo judge the verdicts.
verdict=$(grep -E '^preflight: (GO|NO-GO)' "$TMP/dance_off.log")
[ -n "$verdict" ] && say "$verdict" || fail "preflight gave no verdict"
# (background jobs of a script ignore SIGINT: roslaunch stops on SIGTERM)
kill "$RVIZ_PID" "$ECHO_PID" 2>/dev/null
wait "$RVIZ_PID" "$ECHO_PID" 2>/dev/null
grep -q 'SPHERE_LIST\|type: 7' "$TMP/markers.log" \
  || fail "no skeleton markers: $(tail -3 "$TMP/markers.log")"
grep -rqs "fake python3 ran" "$TMP"/*.log "$TMP/ros/log" \
  && fail "something ran the python3 first on PATH"
if run "rosrun hri_sync verify_decisions $bag" > "$TMP/verify.log" 2>&1; then
  say "verify_decisions: $(tail -n 1 "$TMP/verify.log")"
else
  cat "$TMP/verify.log"
  fail "verify_decisions"
fi

# report: exit 0 (every round passed) or 1 (a verdict failed) both mean it ran.
# With --export mcap: the MCAP and its layouts beside the bag's copy, and
# the shipped layouts installed (docs/viewers.md).
run "rosrun hri_sync report $bag --out $TMP/report --export mcap --mcap-dir $TMP/report" > "$TMP/report.log" 2>&1
code=$?
mcap=$TMP/report/$(basename "${bag%.bag}").mcap
if [ $code -le 1 ] && [ -s "$TMP/report/index.html" ] && [ -s "$mcap" ] \
    && [ -s "${mcap%.mcap}.plotjuggler.xml" ] \
    && [ -s "$share/config/layouts/hri_sync.foxglove.json" ]; then
  say "report: $TMP/report/index.html, $mcap (exit $code)"
else
  tail -20 "$TMP/report.log"
  fail "report (exit $code)"
fi

say "system.launch"
run "roslaunch --wait hri_sync system.launch dur:=1 rounds:=1 ntp_port:=$(free_port)" \
  > "$TMP/system.log" 2>&1 || { tail -20 "$TMP/system.log"; fail "system.launch"; }

say "C++ tools"
uri="virtual://$share/data/motion/cmu_60_01_salsa.track?res=320x240"
run "rosrun hri_sync record_oni '$uri' $TMP/x.oni 1 && rosrun hri_sync oni_info $TMP/x.oni \
     && rosrun hri_sync tracker_eval --track $share/data/motion/cmu_60_01_salsa.track --seconds 1" \
  > "$TMP/tools.log" 2>&1 || { tail -20 "$TMP/tools.log"; fail "C++ tools"; }

# No node died on the way (a respawned node that cannot start, e.g. for a
# module the install left out, would otherwise loop unseen); preflight's
# exit status is its verdict (1: NO-GO), judged above.
died=$(grep -ho '\[[^]]*\] process has died' "$TMP"/*.log | sed 's/^\[[0-9;]*m//' \
  | grep -v '^\[preflight-[0-9]*\]' | sort | uniq -c)
[ -z "$died" ] || fail "nodes died: $(echo $died)"

# Nothing this test started outlives it (roscore, roslaunch and its nodes).
kill "$MASTER_PID" 2>/dev/null && wait "$MASTER_PID" 2>/dev/null
for _ in $(seq 50); do pgrep -f "$TMP/" >/dev/null || break; sleep 0.2; done
left=$(pgrep -fa "$TMP/")
[ -z "$left" ] || { fail "processes left running: $left"; pkill -f "$TMP/"; }

[ $status = 0 ] && say "all passed"
exit $status
