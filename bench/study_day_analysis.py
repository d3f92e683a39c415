"""The analysis of a study-day run (``bench/study_day.py --analyze OUT``).

Reads OUT/study_day.json (the run's checkpoint) and the split bags
OUT/bags/session_N.bag as one session: counts every client's captured
frames in each round's window across the splits against the frames its
result used, runs ``verify_decisions`` and ``report`` on all the bags at
once, plots every node's RSS over the run (OUT/rss.png) and each round's
clock agreement and decision latency (OUT/rounds.png), and writes
OUT/analysis.json.  Needs the workspace sourced (rosbag, rosrun), no ROS
master.
"""
import glob
import json
import os
import re
import struct
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import study_day as sd  # noqa: E402


def split_bags(out):
    """(closed bags in split order, bags still being written)."""
    def index(path):
        m = re.search(r'_(\d+)\.bag', path)
        return int(m.group(1)) if m else -1
    bags = sorted(glob.glob(os.path.join(out, 'bags', '*.bag')), key=index)
    active = sorted(glob.glob(os.path.join(out, 'bags', '*.bag.active')))
    return bags, active


def read_bags(paths, clients):
    """(captured stamps per client sorted, results {(round, client): msg},
    decisions {round: msg}, boundaries: each later bag's first time)."""
    import rosbag
    stamps = {c: [] for c in clients}
    results, decisions, boundaries = {}, {}, []
    topics = ['/%s/captured' % c for c in clients] + [
        '/client_result', '/decision']
    for i, path in enumerate(paths):
        with rosbag.Bag(path) as bag:
            if i:
                boundaries.append(bag.get_start_time())
            for topic, msg, _ in bag.read_messages(topics=topics, raw=True):
                if topic.endswith('/captured'):
                    _, sec, nsec = struct.unpack_from('<III', msg[1], 0)
                    stamps[topic.split('/')[1]].append(sec + nsec * 1e-9)
                    continue
                m = msg[4]()
                m.deserialize(msg[1])
                if topic == '/decision':
                    decisions[m.round] = m
                else:
                    results[(m.round, m.client_id)] = m
    for c in stamps:
        stamps[c].sort()
    return stamps, results, decisions, boundaries


def frames_across_splits(stamps, results, boundaries, rate):
    """Per round and client: frames its result used, captured frames in
    the bags inside its window, and the bag splits inside the window."""
    rows, lost, straddling = [], 0, 0
    for (n, c), r in sorted(results.items()):
        start = r.capture_start.to_sec()
        end = r.capture_end.to_sec()
        used = r.frames + r.frames_rejected
        in_bag = sd.count_in_window(stamps.get(c, []), start, end)
        splits = sd.straddles(start, end, boundaries)
        straddling += bool(splits)
        lost += max(0, used - in_bag)
        rows.append({'round': n, 'client': c, 'result_frames': used,
                     'bag_frames': in_bag, 'splits_in_window': len(splits),
                     'expected_at_rate': int(round(rate * (end - start)))})
    missing = [r for r in rows if r['bag_frames'] < r['result_frames']]
    return {'windows': len(rows), 'windows_across_a_split': straddling,
            'frames_lost': lost, 'windows_missing_frames': missing[:20],
            'bag_frames_total': sum(r['bag_frames'] for r in rows),
            'result_frames_total': sum(r['result_frames'] for r in rows),
            'expected_at_rate_total': sum(r['expected_at_rate']
                                          for r in rows),
            'met': bool(rows) and not missing}


def run_tool(argv, timeout):
    """(exit status, stdout lines) of a tool."""
    try:
        p = subprocess.run(argv, stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True,
                           timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, ['timed out after %d s' % timeout]
    return p.returncode, p.stdout.splitlines()


def verify(bags, decisions, out):
    """verify_decisions on all the bags: its status and which decided
    rounds it checked as agreeing."""
    code, lines = run_tool(['rosrun', 'hri_sync', 'verify_decisions']
                           + bags, 3600)
    with open(os.path.join(out, 'verify_decisions.txt'), 'w') as f:
        f.write('\n'.join(lines) + '\n')
    ok_rounds = set()
    bad_rounds = set()
    for line in lines:
        m = re.match(r'\s*(\d+)\s+(.*)$', line)
        if not m or int(m.group(1)) not in decisions:
            continue
        n, rest = int(m.group(1)), m.group(2)
        if 'robot' in rest.split()[:1]:
            if 'FAIL' in rest or 'wrong' in rest:
                bad_rounds.add(n)
            continue
        (bad_rounds if 'FAIL' in rest or 'differ' in rest
         else ok_rounds).add(n)
    return {'exit_status': code, 'decisions_in_bags': len(decisions),
            'rounds_listed': len(ok_rounds | bad_rounds),
            'rounds_with_problems': sorted(bad_rounds),
            'last_lines': lines[-6:],
            'met': code == 0 and not bad_rounds}


def report(bags, decisions, out):
    """report on all the bags: its status and its rounds' verdicts."""
    rdir = os.path.join(out, 'report')
    code, lines = run_tool(['rosrun', 'hri_sync', 'report'] + bags
                           + ['--out', rdir], 3600)
    verdicts = {}
    try:
        with open(os.path.join(rdir, 'summary.json')) as f:
            summary = json.load(f)
        for r in summary.get('rounds', []):
            verdicts[r.get('round')] = r.get('verdict', r.get('ok'))
    except (OSError, ValueError, AttributeError):
        summary = None
    return {'exit_status': code, 'decisions_in_bags': len(decisions),
            'rounds_in_summary': len(verdicts),
            'verdicts': sorted({str(v) for v in verdicts.values()}),
            'last_lines': lines[-4:], 'html': os.path.join(rdir,
                                                           'index.html'),
            'met': code == 0}


def plot(run, out):
    """OUT/rss.png (every node's RSS, MB, over the run) and OUT/rounds.png
    (clock agreement and decision latency per round)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    samples = run['samples']
    span = run['config']['compare_minutes'] / 60.0
    fig, ax = plt.subplots(figsize=(9, 5))
    for k in sorted(samples[-1]['rss_kb']):
        xs = [s['t_s'] / 3600 for s in samples if s['rss_kb'].get(k)]
        ys = [s['rss_kb'][k] / 1024 for s in samples if s['rss_kb'].get(k)]
        if ys and max(ys) > 20:
            ax.plot(xs, ys, lw=1, label=k)
    ax.axvline(span, color='k', ls=':', lw=1)
    ax.set(xlabel='hours since start', ylabel='RSS, MB',
           title='RSS of every node of the study day')
    ax.legend(fontsize=6, ncol=3, loc='upper left')
    fig.tight_layout()
    fig.savefig(os.path.join(out, 'rss.png'), dpi=100)
    rounds = [r for r in run['rounds'] if r.get('end_s') is not None]
    fig, axes = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    for ax, key, label in ((axes[0], 'clock_agreement_ms',
                            'clock agreement, ms'),
                           (axes[1], 'decision_ms', 'decision latency, ms')):
        pts = [(r['end_s'] / 3600, r[key]) for r in rounds
               if r.get(key) is not None]
        ax.plot([p[0] for p in pts], [p[1] for p in pts], '.', ms=4)
        ax.set_ylabel(label)
    axes[1].set_xlabel('hours since start (window end)')
    fig.tight_layout()
    fig.savefig(os.path.join(out, 'rounds.png'), dpi=100)
    plt.close('all')
    return [os.path.join(out, 'rss.png'), os.path.join(out, 'rounds.png')]


def analyze(out):
    """Everything above; the JSON (also written to OUT/analysis.json)."""
    with open(os.path.join(out, 'study_day.json')) as f:
        run = json.load(f)
    cfg = run['config']
    result = {'run_finished': run['finished'], 'summary': run['summary']}
    try:
        result['plots'] = plot(run, out)
    except ImportError as e:
        result['plots'] = 'no matplotlib: %s' % e
    bags, active = split_bags(out)
    result['bags'] = {'closed': len(bags), 'still_written': active}
    if bags:
        stamps, results, decisions, bounds = read_bags(bags, cfg['clients'])
        result['frames_across_splits'] = frames_across_splits(
            stamps, results, bounds, cfg['rate_hz'])
        result['verify_decisions'] = verify(bags, decisions, out)
        result['report'] = report(bags, decisions, out)
        decided = [r['round'] for r in run['rounds'] if r.get('decided')]
        result['decisions_recorded_vs_seen'] = {
            'seen_live': len(decided), 'in_bags': len(decisions),
            'missing_from_bags': sorted(set(decided) - set(decisions))[:20]}
    sd.write_json(os.path.join(out, 'analysis.json'), result)
    return result
