#!/usr/bin/python3
"""`make demo-sensors`: one round of four clients with four kinds of sensor.

Runs launch/sensors.launch on its own ROS master: a skeleton client (a
salsa dancer replayed by skeleton_sensor), an IMU client (a synthetic
wrist IMU of that dancer, data/sensors/imu_wrist.bag), an audio client
(espeak-ng speech, data/sensors/speech.wav, by audio_sensor) and a camera
client (the dancer rendered as 16UC1 depth, data/sensors/
camera_dancer.bag), each on its own wrong, drifting clock (libfaketime).
Prints the window (global time), each client's result (status, value
and unit, frames, coverage, first-frame offset, timing uncertainty) and
the time each result came after the window's end.  Options pass on to
the launch file as name:=value (e.g. dur:=10 joints:=true).  Exits
non-zero unless every client's result is ok.
"""
import os
import signal
import socket
import subprocess
import sys
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
CLIENTS = ('skeleton', 'imu', 'audio', 'camera')
# The unit of a result whose processor does not say (in 'unit').
UNITS = {'skeleton': 'm^2/s^2'}


def free_port():
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def report(capture, results, acks):
    """The lines to print for the window and its results."""
    from hri_sync.wire.protocol import Capture
    w = Capture.from_msg(capture)
    lines = ['round %d: window [%.3f, %.3f) global s (CR_T %.3f + STR_AFT '
             '%.3f s, DUR %.1f s)' % (w.round, w.start, w.end, w.cr_t,
                                      w.str_aft, w.dur)]
    lines += ['  %-9s clock %+.4f s off the time server (measured at the '
              'ACK, +/- %.3f ms)' % (c, -a.offset, a.uncertainty * 1e3)
              for c, a in sorted(acks.items())]
    for c in sorted(results):
        r, t = results[c]
        d = {kv.key: kv.value for kv in r.diagnostics}
        lines.append(
            '  %-9s %-7s value %10.4g %-9s %5d frames (%d rejected), '
            'coverage %.2f, first frame +%.1f ms, timing uncertainty '
            '%.2f ms, result %.0f ms after the window' % (
                c, r.status, r.value, d.get('unit', UNITS.get(c, '')),
                r.frames,
                r.frames_rejected, r.coverage, r.first_frame_offset * 1e3,
                r.timing_uncertainty * 1e3, (t - w.end) * 1e3))
    return lines


def main():
    import rosgraph
    import rospy
    from hri_sync.msg import CaptureData, ClientResult, SyncAck
    from hri_sync.ros.replay import start_round_when_delivering
    args = ['ntp_port:=%d' % free_port(), 'rounds:=0'] + sys.argv[1:]
    clients = list(CLIENTS) + (['joints'] if 'joints:=true' in args else [])
    port = free_port()
    os.environ['ROS_MASTER_URI'] = 'http://localhost:%d' % port
    log_path = '/tmp/hri_sync_demo_sensors_%s.log' % time.strftime(
        '%Y%m%d_%H%M%S')
    print('sensors demo: roslaunch hri_sync sensors.launch %s\n(the full '
          'roslaunch output goes to %s)' % (' '.join(args), log_path),
          flush=True)
    with open(log_path, 'w') as log:
        launch = subprocess.Popen(
            ['roslaunch', '-p', str(port), 'hri_sync', 'sensors.launch']
            + args, stdout=log, stderr=subprocess.STDOUT,
            start_new_session=True)
        try:
            deadline = time.monotonic() + 60
            while not rosgraph.is_master_online():
                if time.monotonic() > deadline or launch.poll() is not None:
                    sys.exit('sensors demo: no ROS master (see %s)'
                             % log_path)
                time.sleep(0.5)
            rospy.init_node('demo_sensors', disable_signals=True)
            captures, results = [], {}
            acks = {}
            rospy.Subscriber('/capture_data', CaptureData, captures.append)
            rospy.Subscriber('/sync_ack', SyncAck, lambda m: acks.__setitem__(
                m.client_id, m) if m.ok else None)
            rospy.Subscriber('/client_result', ClientResult,
                             lambda m: results.__setitem__(
                                 m.client_id, (m, time.time())))
            # The round once every sensor delivers (a replay starts when
            # its client's clock is known).
            threading.Thread(target=start_round_when_delivering,
                             args=(clients, 120.0), daemon=True).start()
            deadline = time.monotonic() + 300
            while (len(results) < len(clients) or not captures) and \
                    launch.poll() is None and time.monotonic() < deadline:
                time.sleep(0.2)
        finally:
            if launch.poll() is None:
                os.killpg(launch.pid, signal.SIGINT)
                try:
                    launch.wait(30)
                except subprocess.TimeoutExpired:
                    os.killpg(launch.pid, signal.SIGKILL)
    if not captures:
        sys.exit('sensors demo: no round started (see %s)' % log_path)
    print('\n'.join(report(captures[0], results, acks)))
    bad = [c for c in clients if c not in results
           or results[c][0].status != ClientResult.OK]
    if bad:
        sys.exit('sensors demo: no ok result from %s (see %s)'
                 % (', '.join(bad), log_path))


if __name__ == '__main__':
    main()
