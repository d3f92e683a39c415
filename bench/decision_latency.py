#!/usr/bin/python3
"""Decision latency of dance-off rounds at any sensor rate (JSON).

    source <ws>/devel/setup.bash
    /usr/bin/python3 bench/decision_latency.py --rate 500 --dur 60 --clients 2

Runs, on a ROS master and NTP port of its own, one roslaunch of: the time
server, the server (CM + DM, ``--rounds`` rounds of DUR = ``--dur`` s),
and ``--clients`` clients c1..cN, each its own ``client.launch`` (CPM +
DPM with SkeletonExpressiveness, device stamps) and its own
``skeleton_sensor`` replaying salsa at ``--rate`` Hz (every client has
its own sensor, as at a real site), and ``rosbag record`` of every
client's captured stream, the results and the decisions.  The bench itself
is a ROS node stamping what it receives on the true clock.

Measured per round: window end -> Decision received, window end -> each
ClientResult received (true time; the window's end is converted from
global time with the server's clock model, the server running on the
true clock); frames: nominal (rate x dur), sent by the sensor from the
window's first captured frame to its last (the span of their header.seq:
a sensor's publisher numbers every frame it sends, and a frame the sensor
skipped under load takes no number), captured (the result's used +
rejected), recorded (captured frames of the window in the bag), lost
(sent but not captured, plus captured but not recorded); each DPM's
memory (VmRSS before the first round, VmHWM after the last, from
/proc/<pid>/status); each window's error bound
(ClientResult.timing_uncertainty) and the Decision's; the host's 1-minute
load average at the first round and after the last.

Progress goes to stderr; the last stdout line is one JSON object.  Exit
status 0 when every round was decided with every result in (ok, or
partial: a sensor that skipped frames under load) and no frame lost, 1
otherwise, 2 when the setup failed.
"""
import argparse
import json
import math
import os
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time
from xmlrpc.client import ServerProxy

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))), 'support'))
from hri_sync_support.harness import free_port  # noqa: E402

SETUP_TIME = 40.0         # s for the master, chronyd and the first sync
SETUP_PER_CLIENT = 4.0    # s more per client


def log(fmt, *args):
    print('decision_latency: ' + (fmt % args if args else fmt),
          file=sys.stderr, flush=True)



def launch_text(args, ntp_port, bag):
    clients = ['c%d' % (k + 1) for k in range(args.clients)]
    lines = ['<launch>',
             '  <param name="bench/start" command="date +%s.%N"/>',
             '  <include file="$(find hri_sync)/launch/timeserver.launch">',
             '    <arg name="ntp_port" value="%d"/>' % ntp_port,
             '  </include>',
             '  <include file="$(find hri_sync)/launch/server.launch">',
             '    <arg name="clients" value="%s"/>' % ','.join(clients),
             '    <arg name="rounds" value="%d"/>' % args.rounds,
             '    <arg name="dur" value="%g"/>' % args.dur,
             '    <arg name="ntp_port" value="%d"/>' % ntp_port,
             '    <arg name="connect_timeout" value="%g"/>'
             % (15 + SETUP_PER_CLIENT * args.clients),
             '    <arg name="required" value="false"/>',
             '  </include>']
    for k, c in enumerate(clients):
        lines += [
            '  <include file="$(find hri_sync)/launch/client.launch">',
            '    <arg name="client_id" value="%s"/>' % c,
            '    <arg name="ntp_port" value="%d"/>' % ntp_port,
            '    <arg name="processor" value="hri_sync.dance_off.'
            'expressiveness.SkeletonExpressiveness"/>',
            '  </include>',
            '  <node pkg="hri_sync" type="skeleton_sensor" name="sensor" '
            'ns="%s" output="log">' % c,
            '    <param name="client_id" value="%s"/>' % c,
            '    <param name="start_param" value="/bench/start"/>',
            '    <param name="motion" value="cmu_60_01_salsa"/>',
            '    <param name="rate" value="%g"/>' % args.rate,
            '    <param name="seed" value="%d"/>' % (k + 1),
            '  </node>']
    topics = ['/client_result', '/decision', '/capture_data']
    for c in clients:
        topics.append('/%s/captured' % c)
    lines += ['  <node pkg="rosbag" type="record" name="recorder" '
              'output="log" args="-O %s %s"/>' % (bag, ' '.join(topics)),
              '</launch>']
    return '\n'.join(lines) + '\n', clients


def skeleton_stamps(data):
    """(header.seq, header.stamp in s) of a serialized message with a
    header."""
    seq, sec, nsec = struct.unpack_from('<III', data, 0)
    return seq, sec + nsec * 1e-9


def read_bag(path, clients):
    """{client: [(seq, stamp)] of its captured frames}."""
    import rosbag
    out = {c: [] for c in clients}
    with rosbag.Bag(path) as bag:
        for topic, msg, _ in bag.read_messages(raw=True):
            parts = topic.strip('/').split('/')
            if len(parts) == 2 and parts[0] in out:
                out[parts[0]].append(skeleton_stamps(msg[1]))
    return out


def vm(pid, key):
    """A /proc/<pid>/status memory line (kB) in MB, None if gone."""
    try:
        with open('/proc/%d/status' % pid) as f:
            for line in f:
                if line.startswith(key + ':'):
                    return round(int(line.split()[1]) / 1024.0, 1)
    except OSError:
        pass
    return None


def node_pids(master, names):
    """{name: pid} of running ROS nodes."""
    pids = {}
    for name in names:
        try:
            uri = master.lookupNode(name)
            pids[name] = ServerProxy(uri).getPid('/decision_latency')[2]
        except Exception as e:  # a node that is gone has no pid to read
            log('no pid for %s: %s', name, e)
    return pids


class Listener:
    """Stamps /capture_data, /client_result and /decision on arrival with
    the true clock."""

    def __init__(self, rospy, msgs, true_time):
        self.true_time = true_time
        self.lock = threading.Lock()
        self.captures, self.results, self.decisions = {}, {}, {}
        self.clock = None
        rospy.Subscriber('/capture_data', msgs.CaptureData, self.on_capture)
        rospy.Subscriber('/client_result', msgs.ClientResult, self.on_result,
                         queue_size=100)
        rospy.Subscriber('/decision', msgs.Decision, self.on_decision)
        rospy.Subscriber('/server/clock_state', msgs.ClockState,
                         self.on_clock)

    def on_clock(self, msg):
        if msg.ok:
            self.clock = msg

    def on_capture(self, msg):
        with self.lock:
            self.captures[msg.round] = msg

    def on_result(self, msg):
        t = self.true_time()
        with self.lock:
            self.results.setdefault(msg.round, {})[msg.client_id] = (t, msg)

    def on_decision(self, msg):
        t = self.true_time()
        with self.lock:
            self.decisions.setdefault(msg.round, (t, msg))


def diagnostic(result, key, default):
    """A ClientResult diagnostic's value."""
    for kv in result.diagnostics:
        if kv.key == key:
            return kv.value
    return default


def to_true(clock, global_time):
    """Global -> the server's local clock, which is the true clock."""
    from hri_sync.clock.ros_clock_state import model_from_msg
    return model_from_msg(clock).to_local(global_time)


def analyse(args, listener, clients, frames):
    from hri_sync.wire.protocol import Capture
    from hri_sync.clock.skew import percentiles
    decision_lat, result_lat, bounds, decision_bounds = [], [], [], []
    rounds, lost_total, problems = [], 0, []
    for n in sorted(listener.captures):
        cap = listener.captures[n]
        window = Capture.from_msg(cap)
        start, end = window.start, window.end
        end_true = to_true(listener.clock, end)
        row = {'round': n, 'clients': {}}
        if n in listener.decisions:
            t, d = listener.decisions[n]
            row['decision_latency_ms'] = round((t - end_true) * 1e3, 2)
            row['outcome'] = d.outcome
            row['decision_timing_uncertainty_ms'] = round(
                d.timing_uncertainty * 1e3, 4)
            decision_lat.append(t - end_true)
            decision_bounds.append(d.timing_uncertainty)
        else:
            problems.append('round %d: no decision' % n)
        for c in clients:
            got = listener.results.get(n, {}).get(c)
            if got is None:
                problems.append('round %d: no result from %s' % (n, c))
                continue
            t, r = got
            kept = [s for s in frames[c] if start <= s[1] < end]
            seqs = [q for q, _ in kept]
            sent = max(seqs) - min(seqs) + 1 if seqs else 0
            captured = r.frames + r.frames_rejected
            lost = max(0, sent - captured) + max(0, captured - len(kept))
            lost_total += lost
            result_lat.append(t - end_true)
            bounds.append(r.timing_uncertainty)
            row['clients'][c] = {
                'status': r.status,
                'result_latency_ms': round((t - end_true) * 1e3, 2),
                'sent': sent, 'captured': captured, 'recorded': len(kept),
                'lost': lost,
                'timing_uncertainty_ms': round(r.timing_uncertainty * 1e3,
                                               4),
                'device_map_residual_ms': round(float(diagnostic(
                    r, 'device_map_residual', 'nan')) * 1e3, 4),
                'completed_by': diagnostic(r, 'completed_by', '')}
            if r.status not in ('ok', 'partial'):
                problems.append('round %d: %s %s' % (n, c, r.status))
            if len(kept) != r.frames + r.frames_rejected:
                problems.append('round %d: %s recorded %d of %d captured'
                                % (n, c, len(kept),
                                   r.frames + r.frames_rejected))
        rounds.append(row)
    if lost_total:
        problems.append('%d frames lost' % lost_total)
    if len(listener.captures) < args.rounds:
        problems.append('%d of %d rounds captured'
                        % (len(listener.captures), args.rounds))

    def ms(values):
        return {k: round(v * 1e3, 2) if math.isfinite(v) else None
                for k, v in percentiles(values).items()}
    return {'decision_latency_ms': ms(decision_lat),
            'result_latency_ms': ms(result_lat),
            'timing_uncertainty_ms': {
                'windows': ms(bounds), 'decisions': ms(decision_bounds)},
            'frames_nominal': int(round(args.rate * args.dur)),
            'frames_lost': lost_total, 'rounds': rounds}, problems


def stop(launch):
    """SIGINT to the launch's process group, then SIGKILL if need be."""
    if launch.poll() is not None:
        return
    os.killpg(launch.pid, signal.SIGINT)
    try:
        launch.wait(timeout=30)
    except subprocess.TimeoutExpired:
        os.killpg(launch.pid, signal.SIGKILL)
        launch.wait()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--rate', type=float, default=20.0, help='sensor Hz')
    ap.add_argument('--dur', type=float, default=60.0, help='DUR, s')
    ap.add_argument('--clients', type=int, default=2)
    ap.add_argument('--rounds', type=int, default=3)
    ap.add_argument('--keep', action='store_true',
                    help='keep the bag and the launch log')
    args = ap.parse_args()
    if args.rate <= 0 or args.dur <= 0 or args.clients < 1 or \
            args.rounds < 1:
        ap.error('--rate, --dur, --clients and --rounds must be positive')

    port, ntp_port = free_port(), free_port()
    work = tempfile.mkdtemp(prefix='decision_latency_')
    bag = os.path.join(work, 'bench.bag')
    text, clients = launch_text(args, ntp_port, bag)
    launch_file = os.path.join(work, 'bench.launch')
    with open(launch_file, 'w') as f:
        f.write(text)
    os.environ['ROS_MASTER_URI'] = 'http://localhost:%d' % port
    launch_log = open(os.path.join(work, 'roslaunch.log'), 'w')
    log('%d clients at %g Hz, %d rounds of %g s; work dir %s',
        args.clients, args.rate, args.rounds, args.dur, work)
    launch = subprocess.Popen(['roslaunch', '-p', str(port), launch_file],
                              stdout=launch_log, stderr=subprocess.STDOUT,
                              start_new_session=True)
    status = 2
    try:
        import rosgraph
        import rospy
        import hri_sync.msg as msgs
        from hri_sync.clock.truth import true_time
        master = rosgraph.Master('/decision_latency')
        deadline = time.time() + 30
        while not master.is_online():
            if time.time() > deadline or launch.poll() is not None:
                raise RuntimeError('no ROS master on port %d' % port)
            time.sleep(0.2)
        rospy.init_node('decision_latency', disable_signals=True)
        listener = Listener(rospy, msgs, true_time)
        dpms = ['/%s/dpm' % c for c in clients]
        deadline = time.time() + SETUP_TIME + \
            SETUP_PER_CLIENT * args.clients
        while not listener.captures and time.time() < deadline:
            time.sleep(0.1)
        if not listener.captures:
            raise RuntimeError('no capture_data within the setup time '
                               '(see %s)' % launch_log.name)
        pids = node_pids(master, dpms)
        load = [round(os.getloadavg()[0], 2)]
        rss_before = {n: vm(p, 'VmRSS') for n, p in pids.items()}
        status = 1
        budget = args.rounds * (args.dur + 10.0) + 10.0
        deadline = time.time() + budget
        while len(listener.decisions) < args.rounds and \
                time.time() < deadline and launch.poll() is None:
            time.sleep(0.2)
        # The last window's captured frames to the bag: each DPM sends
        # the last 2 s (~republish_delay) at 1000 a second.
        time.sleep(3.0 + args.rate * 2.0 / 1000.0)
        peak = {n: vm(p, 'VmHWM') for n, p in pids.items()}
        load.append(round(os.getloadavg()[0], 2))
        stop(launch)
        frames = read_bag(bag, clients)
        out, problems = analyse(args, listener, clients, frames)
        out.update({'rate_hz': args.rate, 'dur_s': args.dur,
                    'clients': args.clients, 'load_average': load,
                    'dpm_rss_before_mb': rss_before, 'dpm_peak_mb': peak,
                    'problems': problems, 'ok': not problems})
        for p in problems:
            log(p)
        print(json.dumps(out), flush=True)
        status = 0 if not problems else 1
    except (RuntimeError, OSError) as e:
        log('setup failed: %s', e)
        print(json.dumps({'ok': False, 'problems': [str(e)]}), flush=True)
    finally:
        stop(launch)
        launch_log.close()
        if not args.keep and status == 0:
            for name in os.listdir(work):
                os.remove(os.path.join(work, name))
            os.rmdir(work)
    sys.exit(status)


if __name__ == '__main__':
    main()
