#!/usr/bin/python3
"""A study day without a restart: hours of back-to-back rounds (JSON).

    source <ws>/devel/setup.bash
    /usr/bin/python3 bench/study_day.py --hours 2 --out /tmp/study_day
    /usr/bin/python3 bench/study_day.py --analyze /tmp/study_day

One launch, never restarted, on a ROS master of its own (``--port``) and
a time server (chronyd) on a UDP port of its own (``--ntp-port``): the
server (CM + DM, round monitor, recorder), 4 skeleton clients (c1..c4,
skeleton_sensor replaying motion clips at ``--rate`` Hz, each sensor on
the true host clock; c3 and c4 run their CPM and DPM under libfaketime
clocks) and DJ Rob on kobuki_sim with the music.  This process starts
each round on the CM's ``start_round`` service (``--dur`` s windows, the
next one ``--pause`` s after a decision, while DJ Rob gestures) until
``--hours`` have passed, and the recorder splits its bag every
``--split-minutes`` (repeating the latched messages, such as the decision
rule's config, at the start of each part).

Every ``--sample`` s it writes OUT/study_day.json (a checkpoint: the
figures exist whatever happens to the run): per node (every process the
launch started) its RSS, CPU seconds and pid (a changed pid is a
respawn), the bags' bytes on disk, the load average and the host's CPU
share; per round its window, decision, decision latency (the decision's
stamp minus the window's end), frames per client and the clients' clock
agreement (spread of their true clock errors, from the round monitor);
and a summary with the targets (met or not).  ``--analyze OUT`` then
plots RSS over time, reads the split bags as one session (frames of
every round counted across the splits) and runs ``verify_decisions`` and
``report`` on them; it prints one JSON object and writes
OUT/analysis.json.
"""
import argparse
import glob
import json
import math
import os
import re
import signal
import subprocess
import sys
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CLIENTS = ('c1', 'c2', 'c3', 'c4')
MOTIONS = ('cmu_60_01_salsa', 'cmu_61_01_salsa', 'cmu_131_01_walk',
           'cmu_60_04_salsa')
SPEEDS = ('1.0', '0.3', '1.0', '0.6')
CLOCKS = ('', '', '+1.2s x1.0002', '-0.8s x0.9998')
BEARINGS = '[45.0, 15.0, -15.0, -45.0]'


def log(fmt, *args):
    print('study_day: ' + (fmt % args if args else fmt), file=sys.stderr,
          flush=True)


# --- pure helpers (unit-tested) ---------------------------------------------

def parse_vm(status_text, field='VmRSS'):
    """kB of ``field`` in the text of /proc/PID/status; None if absent."""
    for line in status_text.splitlines():
        if line.startswith(field + ':'):
            parts = line.split()
            if len(parts) >= 2 and parts[1].isdigit():
                return int(parts[1])
    return None


def node_key(cmdline):
    """A stable name of a process of the launch from its command line:
    the ROS log name (``__log:=.../c1-cpm-3.log`` gives ``c1-cpm``), else
    ``__name``, else the program (the script after an interpreter) and
    its ``client_id:=`` argument."""
    for arg in cmdline:
        if arg.startswith('__log:='):
            base = os.path.basename(arg[len('__log:='):])
            return re.sub(r'(-\d+)?\.log$', '', base)
    for arg in cmdline:
        if arg.startswith('__name:='):
            return arg[len('__name:='):]
    if not cmdline:
        return '?'
    prog = os.path.basename(cmdline[0])
    if re.match(r'python[0-9.]*$', prog) and len(cmdline) > 1:
        prog = os.path.basename(cmdline[1])
    cid = [a.split(':=', 1)[1] for a in cmdline
           if a.startswith('client_id:=')]
    return prog + ('[%s]' % cid[0] if cid else '')


def unique_keys(keys):
    """``keys`` with repeats numbered: a, a#2, a#3."""
    seen, out = {}, []
    for k in keys:
        seen[k] = seen.get(k, 0) + 1
        out.append(k if seen[k] == 1 else '%s#%d' % (k, seen[k]))
    return out


def percentile(values, q):
    """The ``q`` (0..100) percentile, linear between ranks; NaN if empty."""
    xs = sorted(v for v in values if v is not None and math.isfinite(v))
    if not xs:
        return math.nan
    pos = (len(xs) - 1) * q / 100.0
    lo = int(math.floor(pos))
    hi = min(lo + 1, len(xs) - 1)
    return xs[lo] + (xs[hi] - xs[lo]) * (pos - lo)


def within(first, last, tol):
    """{first, last, change (relative), met}: ``last`` within ``tol``
    (relative) of ``first``, or below it (a smaller figure is better)."""
    if first is None or last is None or not (
            math.isfinite(first) and math.isfinite(last)):
        return {'first': first, 'last': last, 'change': None, 'met': None}
    change = (last - first) / first if first else (
        0.0 if last == first else math.inf)
    return {'first': round(first, 4), 'last': round(last, 4),
            'change': round(change, 4) if math.isfinite(change) else None,
            'met': change <= tol}


def window_p99(rounds, key, t_from, t_to):
    """p99 of ``key`` over the rounds whose window ended in [t_from, t_to)
    (s from the run's start); None without such rounds."""
    xs = [r[key] for r in rounds if r.get(key) is not None
          and r.get('end_s') is not None and t_from <= r['end_s'] < t_to]
    p = percentile(xs, 99)
    return None if math.isnan(p) else p


def compare_windows(rounds, key, span, total, tol=0.2):
    """``key``'s p99 in the first ``span`` s against the last ``span`` s
    of a run of ``total`` s: within ``tol`` (relative)?"""
    first = window_p99(rounds, key, 0.0, span)
    last = window_p99(rounds, key, total - span, total + 1e9)
    out = within(first, last, tol)
    out['rounds'] = [sum(1 for r in rounds if r.get(key) is not None and
                         r.get('end_s') is not None and a <= r['end_s'] < b)
                     for a, b in ((0.0, span), (total - span, total + 1e9))]
    return out


def by_window(rounds, samples, span):
    """The run in windows of ``span`` s (by window end): per window its
    rounds, clock agreement and decision latency p50 and p99 (ms), the
    lowest share of the nominal frames a result got, and the mean load
    average of its samples: how the figures move over hours, and with
    the machine's load."""
    def p(xs, q):
        v = percentile(xs, q)
        return None if math.isnan(v) else round(v, 3)
    ends = [r['end_s'] for r in rounds if r.get('end_s') is not None]
    out = []
    for k in range(int(max(ends, default=-1) // span) + 1):
        a, b = k * span, (k + 1) * span
        rs = [r for r in rounds if r.get('end_s') is not None
              and a <= r['end_s'] < b]
        clock = [r.get('clock_agreement_ms') for r in rs]
        lat = [r.get('decision_ms') for r in rs]
        loads = [s['load_1min'] for s in samples if a <= s['t_s'] < b]
        ratios = [n / r['frames_expected'] for r in rs
                  if r.get('frames_expected')
                  for n in r.get('frames', {}).values()]
        out.append({'from_min': round(a / 60), 'rounds': len(rs),
                    'clock_p50_ms': p(clock, 50), 'clock_p99_ms': p(clock, 99),
                    'decision_p50_ms': p(lat, 50),
                    'decision_p99_ms': p(lat, 99),
                    'frames_min_share': round(min(ratios), 3)
                    if ratios else None,
                    'load_mean': round(sum(loads) / len(loads), 1)
                    if loads else None})
    return out


def rss_growth(samples, baseline_s, tol=0.1):
    """Per node: RSS (kB) at the first sample at or after ``baseline_s``
    against the last sample's, within ``tol``?  Nodes that were not in
    both are left out."""
    base = next((s for s in samples if s['t_s'] >= baseline_s), None)
    if base is None or not samples:
        return {}
    last = samples[-1]
    out = {}
    for k, rss in sorted(base['rss_kb'].items()):
        end = last['rss_kb'].get(k)
        if rss and end:
            out[k] = within(float(rss), float(end), tol)
    return out


def clock_spread(errors_ms):
    """Clock agreement of a round: the spread (max - min) of the clients'
    true clock errors, ms; None with fewer than 2."""
    xs = [v for v in errors_ms.values() if v is not None]
    return max(xs) - min(xs) if len(xs) >= 2 else None


def count_in_window(stamps, start, end):
    """How many of the sorted ``stamps`` fall in [start, end)."""
    import bisect
    return bisect.bisect_left(stamps, end) - bisect.bisect_left(stamps, start)


def parse_speeds(text):
    """The 4 clients' motion speeds from 'S1,S2,S3,S4' (each > 0), as
    strings for the launch file; ValueError names what is wrong."""
    parts = [p.strip() for p in text.split(',')]
    if len(parts) != len(CLIENTS):
        raise ValueError('%d speeds given, one per client (%s) needed'
                         % (len(parts), ', '.join(CLIENTS)))
    for p in parts:
        try:
            value = float(p)
        except ValueError:
            value = math.nan
        if not (value > 0 and math.isfinite(value)):
            raise ValueError('speed %r is not a number > 0' % p)
    return tuple(parts)


def straddles(start, end, boundaries):
    """The bag boundaries (s) inside the window (start, end)."""
    return [b for b in boundaries if start < b < end]


# --- the launch --------------------------------------------------------------

def launch_text(opts, bag):
    """The launch file: site server, 4 skeleton clients, DJ Rob + music."""
    master = 'http://localhost:%d' % opts.port
    lines = [
        '<launch>',
        '  <include file="$(find hri_sync)/launch/site_server.launch">',
        '    <arg name="master" value="%s"/>' % master,
        '    <arg name="ntp_server" value="127.0.0.1"/>',
        '    <arg name="ntp_port" value="%d"/>' % opts.ntp_port,
        '    <arg name="bind_address" value="127.0.0.1"/>',
        '    <arg name="allow" value="127.0.0.1"/>',
        '    <arg name="participants" value="%s"/>' % ','.join(CLIENTS),
        '    <arg name="robot" value="sim"/>',
        '    <arg name="music" value="true"/>',
        '    <arg name="play_music" value="false"/>',
        '    <arg name="rounds" value="0"/>',
        '    <arg name="dur" value="%g"/>' % opts.dur,
        '    <arg name="cm_required" value="false"/>',
        '    <arg name="truth_clients" value="%s"/>' % ','.join(CLIENTS),
        '    <arg name="participant_bearings" value="%s"/>' % BEARINGS,
        '    <arg name="summary_file" value="%s"/>'
        % os.path.join(opts.out, 'rounds_monitor.json'),
        '    <arg name="preflight" value="false"/>',
        '    <arg name="aggregator" value="false"/>',
        '    <arg name="bag" value="%s"/>' % bag,
        '    <arg name="bag_options" value="--split --duration=%dm '
        '--repeat-latched"/>'
        % opts.split_minutes,
        '  </include>']
    for i, c in enumerate(CLIENTS):
        lines += [
            '  <include file="$(find hri_sync)/launch/site_client.launch">',
            '    <arg name="master" value="%s"/>' % master,
            '    <arg name="ntp_server" value="127.0.0.1"/>',
            '    <arg name="ntp_port" value="%d"/>' % opts.ntp_port,
            '    <arg name="client_id" value="%s"/>' % c,
            '    <arg name="motion" value="%s"/>' % MOTIONS[i],
            '    <arg name="speed" value="%s"/>' % opts.speeds[i],
            '    <arg name="rate" value="%g"/>' % opts.rate,
            '    <arg name="seed" value="%d"/>' % (i + 1),
            '    <arg name="clock" value="%s"/>' % CLOCKS[i],
            '  </include>']
    lines += [
        '  <include file="$(find hri_sync)/launch/site_robot.launch">',
        '    <arg name="master" value="%s"/>' % master,
        '    <arg name="ntp_server" value="127.0.0.1"/>',
        '    <arg name="ntp_port" value="%d"/>' % opts.ntp_port,
        '    <arg name="robot" value="sim"/>',
        '    <arg name="music" value="true"/>',
        '    <arg name="participant_bearings" value="%s"/>' % BEARINGS,
        '  </include>',
        '</launch>']
    return '\n'.join(lines) + '\n'


# --- what the run records ----------------------------------------------------

class Rounds:
    """The rounds as this node sees them: capture orders, results,
    decisions (rospy callbacks; ``rows`` for the JSON)."""

    def __init__(self, rospy, msgs, t0):
        self.t0 = t0
        self.lock = threading.Lock()
        self.rounds = {}
        self.calls = []
        rospy.Subscriber('/capture_data', msgs.CaptureData, self.on_capture,
                         queue_size=100)
        rospy.Subscriber('/client_result', msgs.ClientResult, self.on_result,
                         queue_size=100)
        rospy.Subscriber('/decision', msgs.Decision, self.on_decision,
                         queue_size=100)

    def row(self, n):
        """The row of round ``n`` (created if new; under the lock)."""
        return self.rounds.setdefault(n, {'round': n, 'frames': {},
                                          'status': {}})

    def on_capture(self, m):
        start = m.header.stamp.to_sec() + m.str_aft
        with self.lock:
            r = self.row(m.round)
            r.update(start=start, end=start + m.dur,
                     end_s=round(start + m.dur - self.t0, 3))

    def on_result(self, m):
        with self.lock:
            r = self.row(m.round)
            r['frames'][m.client_id] = m.frames + m.frames_rejected
            r['status'][m.client_id] = m.status
            if m.frames_dropped:
                r.setdefault('dropped', {})[m.client_id] = m.frames_dropped

    def on_decision(self, m):
        now = time.time()
        end = m.window_end.to_sec()
        with self.lock:
            r = self.row(m.round)
            r.update(outcome=m.outcome, winner=m.winner,
                     decided=m.outcome != 'aborted',
                     decision_ms=round((m.header.stamp.to_sec() - end) * 1e3,
                                       3) if end else None,
                     decision_received_ms=round((now - end) * 1e3, 3)
                     if end else None)

    def rows(self, monitor):
        """Rows of the rounds with the round monitor's clock errors."""
        with self.lock:
            rows = [dict(self.rounds[n]) for n in sorted(self.rounds)]
        for r in rows:
            mon = monitor.get(r['round'], {})
            errs = mon.get('clock_error_ms') or {}
            r['clock_error_ms'] = {k: round(v, 4) for k, v in errs.items()}
            spread = clock_spread(errs)
            r['clock_agreement_ms'] = round(spread, 4) \
                if spread is not None else None
            skew = mon.get('start_skew_ms')
            r['start_skew_ms'] = round(skew, 4) if skew is not None else None
            r.pop('start', None)
            r.pop('end', None)
        return rows


def read_monitor(path):
    """{round: row} of the round monitor's summary file (or {})."""
    try:
        with open(path) as f:
            return {r['round']: r for r in json.load(f)}
    except (OSError, ValueError, KeyError, TypeError):
        return {}


def process_sample(launch_pid):
    """{key: (pid, rss kB, cpu s)} of every process under the launch."""
    import psutil
    try:
        procs = psutil.Process(launch_pid).children(recursive=True)
    except psutil.Error:
        return {}
    rows = []
    for p in procs:
        try:
            cmd = p.cmdline()
            with open('/proc/%d/status' % p.pid) as f:
                rss = parse_vm(f.read())
            t = p.cpu_times()
            rows.append((node_key(cmd), p.pid, rss, t.user + t.system))
        except (psutil.Error, OSError):
            continue
    rows.sort(key=lambda r: (r[0], r[1]))
    keys = unique_keys([r[0] for r in rows])
    return {k: r[1:] for k, r in zip(keys, rows)}


def disk_bytes(pattern):
    """Bytes of the files matching ``pattern``."""
    total = 0
    for path in glob.glob(pattern):
        try:
            total += os.path.getsize(path)
        except OSError:
            pass
    return total


def host_cpu():
    """(busy, total) jiffies of the host from /proc/stat."""
    with open('/proc/stat') as f:
        vals = [int(x) for x in f.readline().split()[1:]]
    idle = vals[3] + (vals[4] if len(vals) > 4 else 0)
    return sum(vals) - idle, sum(vals)


# --- the summary ------------------------------------------------------------

def cost(samples, hours):
    """CPU share (cores) of the launch's processes and of the host, disk
    per hour."""
    if len(samples) < 2:
        return {}
    a, b = samples[0], samples[-1]
    dt = b['t_s'] - a['t_s']
    cpu = sum(b['cpu_s'].values()) - sum(
        a['cpu_s'].get(k, 0.0) for k in b['cpu_s'])
    busy = (b['host_busy'] - a['host_busy']) / max(
        1, b['host_total'] - a['host_total'])
    per_node = {k: round((v - a['cpu_s'].get(k, 0.0)) / dt, 4)
                for k, v in sorted(b['cpu_s'].items())} if dt > 0 else {}
    loads = [s['load_1min'] for s in samples]
    return {'launch_cpu_cores': round(cpu / dt, 3) if dt > 0 else None,
            'host_cpu_share': round(busy, 3),
            'host_cores': os.cpu_count(),
            'node_cpu_cores': per_node,
            'load_1min_mean': round(sum(loads) / len(loads), 2),
            'load_1min_max': round(max(loads), 2),
            'bag_mb_per_hour': round(b['bag_bytes'] / 1e6 / hours, 1)
            if hours > 0 else None,
            'bag_mb': round(b['bag_bytes'] / 1e6, 1)}


def restarts(samples, settled_s=0.0):
    """{node: number of pid changes} (a respawn), nodes that vanished,
    from the samples at or after ``settled_s`` (a sample taken while the
    launch starts holds processes that become others)."""
    samples = [s for s in samples if s['t_s'] >= settled_s]
    pids, changes, gone = {}, {}, set()
    for s in samples:
        for k, pid in s['pid'].items():
            if k in pids and pids[k] != pid:
                changes[k] = changes.get(k, 0) + 1
            pids[k] = pid
    if samples:
        gone = set(pids) - set(samples[-1]['pid'])
    return {'pid_changes': changes, 'gone': sorted(gone)}


def summarize(rounds, samples, opts, elapsed):
    """The figures and targets of a run so far."""
    span = opts.compare_minutes * 60.0
    done = [r for r in rounds if 'outcome' in r or
            (r.get('end_s') is not None and r['end_s'] < elapsed - 30)]
    decided = [r for r in done if r.get('decided')]
    rss = rss_growth(samples, span)
    below_rate = [(r['round'], c, n) for r in done
                    for c, n in r['frames'].items()
                    if n < 0.99 * opts.rate * opts.dur]
    clock = compare_windows(rounds, 'clock_agreement_ms', span, elapsed)
    latency = compare_windows(rounds, 'decision_ms', span, elapsed)
    return {
        'elapsed_s': round(elapsed, 1),
        'rounds_done': len(done), 'rounds_decided': len(decided),
        'outcomes': {o: sum(1 for r in done if r.get('outcome') == o)
                     for o in sorted({r.get('outcome') for r in done
                                      if r.get('outcome')})},
        'clock_agreement_p99_ms': window_p99(rounds, 'clock_agreement_ms',
                                             0, 1e9),
        'decision_latency_p99_ms': window_p99(rounds, 'decision_ms', 0, 1e9),
        'frames_per_round_vs_rate': {
            'expected': int(opts.rate * opts.dur),
            'min': min((n for r in done for n in r['frames'].values()),
                       default=None),
            'below_99pct': len(below_rate), 'first': below_rate[:8]},
        'rss_growth': rss,
        'clock_agreement_first_vs_last': clock,
        'decision_latency_first_vs_last': latency,
        'restarts': restarts(samples, min(
            (r['end_s'] - opts.dur for r in done if r.get('end_s')),
            default=0.0)),
        'cost': cost(samples, elapsed / 3600.0),
        'targets': {
            'every_round_decided': bool(done) and len(decided) == len(done),
            'rss_within_10pct': all(v['met'] for v in rss.values())
            if rss else None,
            'clock_p99_within_20pct': clock['met'],
            'decision_p99_within_20pct': latency['met'],
            'sensor_rate_met': not below_rate if done else None,
        }}


def write_json(path, obj):
    """Write ``obj`` to ``path`` at once (a reader never sees half)."""
    tmp = path + '.tmp'
    with open(tmp, 'w') as f:
        json.dump(obj, f, indent=1)
    os.replace(tmp, path)


# --- the run ----------------------------------------------------------------

def drive_rounds(rospy, rounds, opts, deadline, stop):
    """Start rounds on the CM's service until ``deadline`` (time.time())."""
    from std_srvs.srv import Trigger
    name = '/control_module/start_round'
    rospy.wait_for_service(name, timeout=120)
    call = rospy.ServiceProxy(name, Trigger)
    while not stop.is_set() and time.time() < deadline:
        t = time.time()
        try:
            res = call()
            rounds.calls.append({'t': round(t, 3), 'ok': res.success,
                                 'message': res.message[:200]})
            log('round: %s %s', 'ok' if res.success else 'FAILED',
                res.message[:120])
        except rospy.ServiceException as e:
            rounds.calls.append({'t': round(t, 3), 'ok': False,
                                 'message': str(e)[:200]})
            log('start_round failed: %s', e)
            time.sleep(5.0)
        stop.wait(opts.pause)
    stop.set()


def take_sample(launch, opts, t0, last_host):
    """One sample: load, host CPU, bag bytes, every process's pid, RSS,
    CPU seconds."""
    procs = process_sample(launch.pid)
    busy, total = host_cpu()
    return {'t_s': round(time.time() - t0, 1),
            'load_1min': round(os.getloadavg()[0], 2),
            'host_busy': busy, 'host_total': total,
            'bag_bytes': disk_bytes(os.path.join(opts.out, 'bags', '*.bag*')),
            'pid': {k: v[0] for k, v in procs.items()},
            'rss_kb': {k: v[1] for k, v in procs.items()},
            'cpu_s': {k: round(v[2], 2) for k, v in procs.items()}}


def checkpoint(opts, t0, rounds, samples, launch_file, done=False):
    """Write OUT/study_day.json: config, summary, rounds, samples."""
    elapsed = time.time() - t0
    rows = rounds.rows(read_monitor(os.path.join(opts.out,
                                                 'rounds_monitor.json')))
    out = {'benchmark': 'study_day', 'finished': done,
           'started': time.strftime('%Y-%m-%dT%H:%M:%SZ', time.gmtime(t0)),
           'config': {'hours': opts.hours, 'dur_s': opts.dur,
                      'rate_hz': opts.rate, 'clients': list(CLIENTS),
                      'clocks': dict(zip(CLIENTS, CLOCKS)),
                      'speeds': dict(zip(CLIENTS, opts.speeds)),
                      'pause_s': opts.pause,
                      'split_minutes': opts.split_minutes,
                      'sample_s': opts.sample,
                      'compare_minutes': opts.compare_minutes,
                      'ros_port': opts.port, 'ntp_port': opts.ntp_port,
                      'launch_file': launch_file},
           'summary': summarize(rows, samples, opts, elapsed),
           'rounds': rows, 'round_calls': rounds.calls[-5:],
           'samples': samples}
    write_json(os.path.join(opts.out, 'study_day.json'), out)
    return out


def stop_launch(launch):
    """SIGINT to the launch's process group, SIGKILL after 60 s."""
    if launch.poll() is not None:
        return
    os.killpg(launch.pid, signal.SIGINT)
    try:
        launch.wait(60)
    except subprocess.TimeoutExpired:
        os.killpg(launch.pid, signal.SIGKILL)
        launch.wait()


def run(opts):
    """Write the launch file, start it, record until the end."""
    os.makedirs(os.path.join(opts.out, 'bags'), exist_ok=True)
    launch_file = os.path.join(opts.out, 'study_day.launch')
    with open(launch_file, 'w') as f:
        f.write(launch_text(opts, os.path.join(opts.out, 'bags',
                                               'session.bag')))
    uri = 'http://localhost:%d' % opts.port
    os.environ['ROS_MASTER_URI'] = uri
    launch_log = open(os.path.join(opts.out, 'roslaunch.log'), 'w')
    launch = subprocess.Popen(['roslaunch', '-p', str(opts.port),
                               launch_file], stdout=launch_log,
                              stderr=subprocess.STDOUT,
                              start_new_session=True)
    log('roslaunch pid %d, master %s, ntp port %d, out %s', launch.pid, uri,
        opts.ntp_port, opts.out)
    stop = threading.Event()
    try:
        record(opts, launch, launch_file, stop)
    finally:
        stop.set()
        stop_launch(launch)
        launch_log.close()


def record(opts, launch, launch_file, stop):
    """Drive the rounds and sample every --sample s until --hours."""
    import rosgraph
    import rospy
    import hri_sync.msg as msgs
    deadline = time.time() + 60
    while not rosgraph.Master('/study_day').is_online():
        if time.time() > deadline or launch.poll() is not None:
            raise RuntimeError('no ROS master on port %d' % opts.port)
        time.sleep(0.5)
    rospy.init_node('study_day_bench', disable_signals=True)
    t0 = time.time()
    rounds = Rounds(rospy, msgs, t0)
    end = t0 + opts.hours * 3600.0
    driver = threading.Thread(target=drive_rounds, daemon=True,
                              args=(rospy, rounds, opts, end, stop))
    driver.start()
    samples = []
    next_t = t0
    while not stop.is_set() and launch.poll() is None:
        samples.append(take_sample(launch, opts, t0, None))
        out = checkpoint(opts, t0, rounds, samples, launch_file)
        s = out['summary']
        log('%.0f s: %d rounds done, %d decided, load %.2f, bags %.0f MB',
            s['elapsed_s'], s['rounds_done'], s['rounds_decided'],
            samples[-1]['load_1min'], samples[-1]['bag_bytes'] / 1e6)
        next_t += opts.sample
        stop.wait(max(0.0, next_t - time.time()))
    driver.join(opts.dur + 120)
    time.sleep(opts.pause)      # DJ Rob's last gesture into the bag
    samples.append(take_sample(launch, opts, t0, None))
    out = checkpoint(opts, t0, rounds, samples, launch_file, done=True)
    print(json.dumps(out['summary']), flush=True)


# --- the analysis ------------------------------------------------------------

def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--hours', type=float, default=2.0)
    ap.add_argument('--dur', type=float, default=60.0, help='window, s')
    ap.add_argument('--rate', type=float, default=100.0,
                    help='sensor rate, Hz')
    ap.add_argument('--speeds', default=','.join(SPEEDS),
                    help='the 4 clients\' motion speeds (the default '
                    'ends every round within noise: no winner)')
    ap.add_argument('--pause', type=float, default=8.0,
                    help='s after a decision before the next round')
    ap.add_argument('--sample', type=float, default=60.0,
                    help='s between samples (and checkpoints)')
    ap.add_argument('--split-minutes', type=int, default=10)
    ap.add_argument('--compare-minutes', type=float, default=10.0,
                    help='the first and last this many minutes compared')
    ap.add_argument('--port', type=int, default=11411, help='ROS master')
    ap.add_argument('--ntp-port', type=int, default=11497)
    ap.add_argument('--out', default='/tmp/study_day')
    ap.add_argument('--analyze', metavar='OUT',
                    help='analyze the run in OUT (no ROS master needed)')
    ap.add_argument('--tools', default='verify,report',
                    help='with --analyze: verify_decisions and/or report')
    ap.add_argument('--chunks', help='with --analyze: check only these '
                    'chunks (e.g. 3,4: two processes can share the work)')
    ap.add_argument('--watch', action='store_true',
                    help='with --analyze: check the bags as the run closes '
                    'them, until it has finished')
    opts = ap.parse_args()
    try:
        opts.speeds = parse_speeds(opts.speeds)
    except ValueError as e:
        ap.error('--speeds: %s' % e)
    if opts.analyze:
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        import study_day_analysis as sda
        tools = tuple(t for t in opts.tools.split(',') if t)
        if opts.chunks:
            sda.ONLY = {int(k) for k in opts.chunks.split(',')}
        fn = sda.watch if opts.watch else sda.analyze
        print(json.dumps(fn(opts.analyze, tools)))
        return 0
    opts.out = os.path.abspath(opts.out)
    run(opts)
    return 0


if __name__ == '__main__':
    sys.exit(main())
