#!/usr/bin/python3
"""The data path at sensor bandwidth as JSON.

    source <ws>/devel/setup.bash
    /usr/bin/python3 bench/sensor_bandwidth.py --scenario camera --dur 60
    /usr/bin/python3 bench/sensor_bandwidth.py --scenario imu_audio --dur 60

Scenarios (every stream its own client: CPM + DPM of client.launch with
the stock processor, fed by a publisher process of this script stamping
each message with the host clock):

- ``camera``: 2 sensor hosts, each a 30 Hz 640x480 16UC1 depth stream
  (18.4 MB/s, ImageMotion) and a 30 Hz 640x480 rgb8 stream (27.6 MB/s,
  ImageMotion) on a second DPM: clients c1_depth, c1_rgb, c2_depth,
  c2_rgb, 92 MB/s in all;
- ``imu_audio``: 4 hosts, each a 1 kHz sensor_msgs/Imu stream
  (ImuActivity) and 100 Hz hri_sync/AudioChunk of 160 samples (16 kHz,
  AudioLevel): clients c1_imu, c1_audio, ... c4_audio.

Each scenario runs once with the DPMs republishing their captured
samples (``republish on``: this bench subscribes to every ``captured``
topic, as a recorder would, and counts what comes, or with ``--recorder
rosbag`` rosbag record records them) and once without (``off``),
``--rounds`` windows of ``--dur`` s each; with ``--complete-on-last
both`` once with the DPMs' ``complete_on_last`` on (a window is complete
with its last sample, when the sensor's next one is due after its end)
and once off (it waits for that next sample). Per run: frames sent by
each publisher in the window (its own send stamps) and captured (the
result's frames + rejected), their ratio; each result's and the
decision's latency after the window's end, as received here (true clock;
the server runs on it; this process also receives every captured stream
with republish on, so its own load delays it) and as made (their
header.stamp, global, minus the window's end); each DPM's CPU share of
one core over the window (utime + stime from /proc) and its peak RSS
(VmHWM); the publishers' CPU share; the host's 1-minute load average
before and after. Progress to stderr, one JSON object per run on stdout,
then a summary object last.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import decision_latency as dl  # noqa: E402  (its helpers)
from hri_sync.tools.procs import cpu_seconds  # noqa: E402

STREAMS = {   # kind: (rate Hz, processor)
    'depth': (30.0, 'hri_sync.sensors.image.ImageMotion'),
    'rgb': (30.0, 'hri_sync.sensors.image.ImageMotion'),
    'imu': (1000.0, 'hri_sync.sensors.imu.ImuActivity'),
    'audio': (100.0, 'hri_sync.sensors.audio.AudioLevel'),
}
SCENARIOS = {'camera': (2, ('depth', 'rgb')),
             'imu_audio': (4, ('imu', 'audio'))}


def log(fmt, *args):
    print('sensor_bandwidth: ' + (fmt % args if args else fmt),
          file=sys.stderr, flush=True)


# --- the publishers ----------------------------------------------------------

def messages(kind):
    """A cycle of messages of a stream (their data prepared ahead)."""
    import numpy as np
    from sensor_msgs.msg import Image, Imu
    from hri_sync.msg import AudioChunk
    rng = np.random.default_rng(1)
    if kind in ('depth', 'rgb'):
        out = []
        for k in range(30):      # a block crossing a noisy scene in 1 s
            if kind == 'depth':
                a = (2000 + rng.integers(0, 8, (480, 640))).astype('<u2')
                a[140:340, 20 * k:20 * k + 120] = 1200
                enc, step = '16UC1', 1280
            else:
                a = rng.integers(0, 16, (480, 640, 3), dtype=np.uint8)
                a[140:340, 20 * k:20 * k + 120] = 200
                enc, step = 'rgb8', 1920
            out.append(Image(height=480, width=640, encoding=enc,
                             step=step, data=a.tobytes()))
        return out
    if kind == 'imu':
        out = []
        for k in range(1000):
            m = Imu()
            m.orientation_covariance[0] = -1.0
            m.linear_acceleration.x = math.sin(2 * math.pi * k / 500)
            m.linear_acceleration.z = 9.81
            m.angular_velocity.y = 0.5 * math.cos(2 * math.pi * k / 500)
            out.append(m)
        return out
    t = np.arange(16000) / 16000.0
    x = (8000 * np.sin(2 * np.pi * 300 * t) * (t % 1.0 < 0.5)).astype('<i2')
    return [AudioChunk(sample_rate=16000, channels=1,
                       data=x[k:k + 160].tolist())
            for k in range(0, 16000, 160)]


def publish(kind, topic, seconds, out):
    """Publish ``kind`` on ``topic`` for ``seconds`` s at its rate; write
    the send stamps (host clock) to ``out`` (.npy)."""
    import numpy as np
    import rospy
    rospy.init_node('pub_' + topic.strip('/').replace('/', '_'),
                    disable_signals=True)
    msgs = messages(kind)
    pub = rospy.Publisher(topic, type(msgs[0]), queue_size=100,
                          tcp_nodelay=True)
    rate = STREAMS[kind][0]
    period = 1.0 / rate
    sent = []
    time.sleep(2.0)
    end = time.time() + seconds
    tick = time.time()
    k = 0
    while time.time() < end:
        delay = tick - time.time()
        if delay > 0:
            time.sleep(delay)
        msg = msgs[k % len(msgs)]
        now = time.time()
        msg.header.stamp = rospy.Time.from_sec(now)
        pub.publish(msg)
        sent.append(now)
        k += 1
        tick += period
    np.save(out, np.array(sent))


# --- one run ---------------------------------------------------------------

def launch_text(clients, ntp_port, rounds, dur, republish, last, bag=None):
    lines = ['<launch>',
             '  <include file="$(find hri_sync)/launch/timeserver.launch">',
             '    <arg name="ntp_port" value="%d"/>' % ntp_port,
             '  </include>',
             '  <include file="$(find hri_sync)/launch/server.launch">',
             '    <arg name="clients" value="%s"/>' % ','.join(clients),
             '    <arg name="rounds" value="0"/>',
             '    <arg name="dur" value="%g"/>' % dur,
             '    <arg name="ntp_port" value="%d"/>' % ntp_port,
             '    <arg name="connect_timeout" value="%g"/>'
             % (15 + 4 * len(clients)),
             '    <arg name="required" value="false"/>',
             '  </include>']
    for c in clients:
        lines += [
            '  <include file="$(find hri_sync)/launch/client.launch">',
            '    <arg name="client_id" value="%s"/>' % c,
            '    <arg name="ntp_port" value="%d"/>' % ntp_port,
            '    <arg name="processor" value="%s"/>'
            % STREAMS[c.split('_')[1]][1],
            '    <arg name="input" value="/sensors/%s"/>' % c,
            '    <arg name="republish" value="%s"/>' % str(republish).lower(),
            '    <arg name="complete_on_last" value="%s"/>'
            % str(last).lower(),
            '  </include>']
    if bag:
        lines.append('  <node pkg="rosbag" type="record" name="recorder" '
                     'output="log" args="-O %s %s"/>' % (bag, ' '.join(
                         '/%s/captured' % c for c in clients)))
    return '\n'.join(lines + ['</launch>']) + '\n'


def bag_stamps(path, clients):
    """{client: [global header stamps of its captured messages]}."""
    import rosbag
    out = {c: [] for c in clients}
    with rosbag.Bag(path) as bag:
        for topic, msg, _ in bag.read_messages(raw=True):
            c = topic.strip('/').split('/')[0]
            if c in out:
                out[c].append(dl.skeleton_stamps(msg[1])[1])
    return out


class CapturedCounter:
    """Counts the messages on every client's captured topic (AnyMsg: no
    deserialization), by their global header stamp."""

    def __init__(self, rospy, clients):
        self.lock = threading.Lock()
        self.stamps = {c: [] for c in clients}
        for c in clients:
            rospy.Subscriber('/%s/captured' % c, rospy.AnyMsg, self.on, c,
                             queue_size=10000)

    def on(self, raw, client):
        sec, nsec = dl.struct.unpack_from('<II', raw._buff, 4)
        with self.lock:
            self.stamps[client].append(sec + nsec * 1e-9)


def run(args, scenario, republish, last):
    import numpy as np
    hosts, kinds = SCENARIOS[scenario]
    clients = ['c%d_%s' % (h + 1, k) for h in range(hosts) for k in kinds]
    port, ntp_port = dl.free_port(), dl.free_port()
    work = tempfile.mkdtemp(prefix='sensor_bandwidth_')
    launch_file = os.path.join(work, 'bench.launch')
    with open(launch_file, 'w') as f:
        bag = os.path.join(work, 'captured.bag') \
            if republish and args.recorder == 'rosbag' else None
        f.write(launch_text(clients, ntp_port, args.rounds, args.dur,
                            republish, last, bag))
    env = dict(os.environ, ROS_MASTER_URI='http://localhost:%d' % port)
    os.environ['ROS_MASTER_URI'] = env['ROS_MASTER_URI']
    launch_log = open(os.path.join(work, 'roslaunch.log'), 'w')
    log('%s, republish %s, complete on last %s: %d clients, %d round(s) '
        'of %g s; work dir %s', scenario, 'on' if republish else 'off',
        'on' if last else 'off', len(clients), args.rounds, args.dur, work)
    launch = subprocess.Popen(['roslaunch', '-p', str(port), launch_file],
                              stdout=launch_log, stderr=subprocess.STDOUT,
                              start_new_session=True)
    pubs = {}
    setup = 40.0 + 4 * len(clients)
    total = setup + args.rounds * (args.dur + 15.0)
    try:
        import rosgraph
        import rospy
        import hri_sync.msg as msgs
        from hri_sync.clock.truth import true_time
        master = rosgraph.Master('/sensor_bandwidth')
        deadline = time.time() + 30
        while not master.is_online():
            if time.time() > deadline or launch.poll() is not None:
                raise RuntimeError('no ROS master on port %d' % port)
            time.sleep(0.2)
        for c in clients:
            pubs[c] = subprocess.Popen(
                [sys.executable, os.path.abspath(__file__), '--publish',
                 c.split('_')[1], '/sensors/' + c, '%g' % total,
                 os.path.join(work, c + '.npy')], env=env,
                stdout=launch_log, stderr=subprocess.STDOUT)
        rospy.init_node('sensor_bandwidth', disable_signals=True)
        listener = dl.Listener(rospy, msgs, true_time)
        counter = CapturedCounter(rospy, clients) \
            if republish and not bag else None
        # Rounds start on the CM's service once every DPM has samples.
        from hri_sync.ros.replay import start_round_when_delivering
        threading.Thread(target=lambda: [
            start_round_when_delivering(clients, setup)
            for _ in range(args.rounds)], daemon=True).start()
        deadline = time.time() + setup + 30
        while not listener.captures and time.time() < deadline:
            time.sleep(0.1)
        if not listener.captures:
            raise RuntimeError('no capture_data (see %s)' % launch_log.name)
        dpms = dl.node_pids(master, ['/%s/dpm' % c for c in clients])
        window = min(listener.captures)
        from hri_sync.wire.protocol import Capture
        cap = Capture.from_msg(listener.captures[window])
        load = [round(os.getloadavg()[0], 2)]
        start_true = dl.to_true(listener.clock, cap.start)
        time.sleep(max(0.0, start_true - time.time()))
        cpu0 = {n: cpu_seconds(p) for n, p in dpms.items()}
        pcpu0 = {c: cpu_seconds(p.pid) for c, p in pubs.items()}
        t0 = time.time()
        deadline = time.time() + args.rounds * (args.dur + 15.0) + 10
        while len(listener.decisions) < args.rounds and \
                time.time() < deadline and launch.poll() is None:
            time.sleep(0.2)
        t1 = time.time()
        cpu1 = {n: cpu_seconds(p) for n, p in dpms.items()}
        pcpu1 = {c: cpu_seconds(p.pid) for c, p in pubs.items()}
        peak = {n: dl.vm(p, 'VmHWM') for n, p in dpms.items()}
        load.append(round(os.getloadavg()[0], 2))
        # The last captured samples: each DPM sends its last ~2 s
        # (~republish_delay) at 1000 a second after its result.
        time.sleep(3.0 + 2.0 * max(STREAMS[c.split('_')[1]][0]
                                   for c in clients) / 1000.0)
    finally:
        dl.stop(launch)
        for p in pubs.values():
            p.wait()
        launch_log.close()
    republished = bag_stamps(bag, clients) if bag else \
        counter.stamps if counter else None
    out = {'scenario': scenario, 'republish': bool(republish),
           'complete_on_last': bool(last),
           'recorder': (args.recorder if republish else None),
           'dur_s': args.dur, 'rounds': args.rounds,
           'load_average': load, 'clients': {}}
    ratios, result_lat, decision_lat = [], [], []
    result_made, decision_made = [], []
    for n in sorted(listener.captures):
        end_true = dl.to_true(listener.clock,
                              Capture.from_msg(listener.captures[n]).end)
        if n in listener.decisions:
            t, d = listener.decisions[n]
            decision_lat.append(t - end_true)
            decision_made.append(d.header.stamp.to_sec()
                                 - d.window_end.to_sec())
    for c in clients:
        sent_all = np.load(os.path.join(work, c + '.npy'))
        row = {'windows': []}
        for n in sorted(listener.captures):
            w = Capture.from_msg(listener.captures[n])
            s, e = dl.to_true(listener.clock, w.start), \
                dl.to_true(listener.clock, w.end)
            sent = int(np.count_nonzero((sent_all >= s) & (sent_all < e)))
            got = listener.results.get(n, {}).get(c)
            item = {'round': n, 'sent': sent}
            if got:
                t, r = got
                captured = r.frames + r.frames_rejected
                made = r.header.stamp.to_sec() - w.end
                item.update({'status': r.status, 'captured': captured,
                             'captured_ratio': round(captured / sent, 4)
                             if sent else None,
                             'result_made_ms': round(made * 1e3, 1),
                             'result_latency_ms': round((t - e) * 1e3, 1)})
                result_made.append(made)
                if sent:
                    ratios.append(captured / sent)
                result_lat.append(t - e)
                if republished is not None:
                    item['republished'] = sum(
                        1 for x in republished[c] if w.start <= x < w.end)
            row['windows'].append(item)
        name = '/%s/dpm' % c
        if cpu0.get(name) is not None and cpu1.get(name) is not None:
            row['dpm_cpu_share'] = round((cpu1[name] - cpu0[name])
                                         / (t1 - t0), 3)
        row['dpm_peak_rss_mb'] = peak.get(name)
        if pcpu0.get(c) is not None and pcpu1.get(c) is not None:
            row['publisher_cpu_share'] = round((pcpu1[c] - pcpu0[c])
                                               / (t1 - t0), 3)
        row['sent_rate_hz'] = round(len(sent_all) / (
            sent_all[-1] - sent_all[0]), 1) if len(sent_all) > 1 else None
        out['clients'][c] = row
    from hri_sync.clock.skew import percentiles

    def ms(values):
        return {k: round(v * 1e3, 1) if math.isfinite(v) else None
                for k, v in percentiles(values).items()}
    out['captured_ratio'] = {'min': round(min(ratios), 4) if ratios
                             else None,
                             'mean': round(sum(ratios) / len(ratios), 4)
                             if ratios else None}
    out['result_latency_ms'] = ms(result_lat)
    out['result_made_ms'] = ms(result_made)
    out['decision_latency_ms'] = [round(x * 1e3, 1) for x in decision_lat]
    out['decision_made_ms'] = [round(x * 1e3, 1) for x in decision_made]
    shares = [r.get('dpm_cpu_share') for r in out['clients'].values()
              if r.get('dpm_cpu_share') is not None]
    out['dpm_cpu_share_sum'] = round(sum(shares), 3)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--scenario', choices=sorted(SCENARIOS) + ['all'],
                    default='all')
    ap.add_argument('--republish', choices=('on', 'off', 'both'),
                    default='both')
    ap.add_argument('--dur', type=float, default=60.0, help='DUR, s')
    ap.add_argument('--rounds', type=int, default=1)
    ap.add_argument('--recorder', choices=('count', 'rosbag'),
                    default='count',
                    help='with republish on, who receives captured: this '
                    'bench counting (rospy AnyMsg) or rosbag record')
    ap.add_argument('--publish', nargs=4, metavar=('KIND', 'TOPIC', 'S',
                                                   'OUT'),
                    help=argparse.SUPPRESS)
    ap.add_argument('--complete-on-last', choices=('on', 'off', 'both'),
                    default='on', help="the DPMs' complete_on_last "
                    '(client.launch): both runs each scenario with it on '
                    'and off')
    ap.add_argument('--run', nargs=3, metavar=('SCENARIO', 'REPUBLISH',
                                               'LAST'),
                    help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.publish:
        kind, topic, seconds, out = args.publish
        publish(kind, topic, float(seconds), out)
        return
    if args.run:        # one run, in a process of its own (one master)
        s, m, last = args.run[0], args.run[1] == 'on', args.run[2] == 'on'
        try:
            r = run(args, s, m, last)
        except (RuntimeError, OSError) as e:
            log('%s failed: %s', s, e)
            r = {'scenario': s, 'republish': m, 'complete_on_last': last,
                 'error': str(e)}
        print(json.dumps(r), flush=True)
        return
    scenarios = sorted(SCENARIOS) if args.scenario == 'all' \
        else [args.scenario]
    both = {'on': ['on'], 'off': ['off'], 'both': ['on', 'off']}
    runs = []
    for s in scenarios:
        for m in both[args.republish]:
            for last in both[args.complete_on_last]:
                out = subprocess.run(
                    [sys.executable, os.path.abspath(__file__), '--run', s,
                     m, last, '--dur', '%g' % args.dur, '--rounds',
                     str(args.rounds), '--recorder', args.recorder],
                    stdout=subprocess.PIPE, text=True).stdout.strip()
                try:
                    r = json.loads(out.splitlines()[-1])
                except (IndexError, ValueError):
                    r = {'scenario': s, 'republish': m == 'on',
                         'complete_on_last': last == 'on',
                         'error': 'no result: %r' % out[-300:]}
                print(json.dumps(r), flush=True)
                runs.append(r)
    print(json.dumps({'summary': [
        {k: r.get(k) for k in ('scenario', 'republish', 'complete_on_last',
                               'captured_ratio',
                               'result_latency_ms', 'result_made_ms',
                               'decision_latency_ms', 'decision_made_ms',
                               'dpm_cpu_share_sum', 'load_average',
                               'error')} for r in runs]}), flush=True)


if __name__ == '__main__':
    main()
