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
import time

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


def both_forms(names):
    """Each topic name relative (as the site files record them, in the
    system's namespace) and absolute."""
    return [n for name in names for n in (name, '/' + name)]


def read_bags(paths, clients):
    """(captured stamps per client sorted, results {(round, client): msg},
    decisions {round: msg}, boundaries: each later bag's first time)."""
    import rosbag
    stamps = {c: [] for c in clients}
    results, decisions, boundaries = {}, {}, []
    topics = both_forms(['%s/captured' % c for c in clients] + [
        'client_result', 'decision'])
    for i, path in enumerate(paths):
        with rosbag.Bag(path) as bag:
            if i:
                boundaries.append(bag.get_start_time())
            for topic, msg, _ in bag.read_messages(topics=topics, raw=True):
                topic = '/' + topic.lstrip('/')
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


def chunks(paths, size=3):
    """Consecutive parts, ``size`` at a time, each chunk overlapping the
    next by one part: every split between two parts is inside a chunk, so
    every round (shorter than a part) is whole in some chunk."""
    out, i = [], 0
    while paths:
        out.append(paths[i:i + size])
        if i + size >= len(paths):
            return out
        i += size - 1
    return out


def config_bag(first, dst):
    """A bag of what a chunk after the first lacks from the first part:
    the latched /dance_off/config (in the first part only, unless
    --repeat-latched) and DJ Rob's first odometry, the origin of the
    robot check's headings."""
    import rosbag
    odom = False
    with rosbag.Bag(first) as src, rosbag.Bag(dst, 'w') as out:
        for topic, msg, t in src.read_messages(
                topics=both_forms(['dance_off/config', 'odom'])):
            if topic.lstrip('/') == 'odom':
                if odom:
                    continue
                odom = True
            out.write(topic, msg, t)


def chunk_dir(out, k, parts):
    """OUT/chunks/K: the config bag and links to ``parts``, named as the
    parts of one split recording (chunk_0.bag, chunk_1.bag, ...)."""
    d = os.path.join(out, 'chunks', '%02d' % k)
    os.makedirs(d, exist_ok=True)
    names = [os.path.join(d, 'chunk_0.bag')]
    if not os.path.exists(names[0]):
        config_bag(parts[0] if k == 0 else
                   os.path.join(os.path.dirname(parts[0]), 'session_0.bag'),
                   names[0])
    for i, p in enumerate(parts):
        link = os.path.join(d, 'chunk_%d.bag' % (i + 1))
        if not os.path.lexists(link):
            os.symlink(os.path.abspath(p), link)
        names.append(link)
    return d, names


def verify_lines(lines):
    """{round: ok} of verify_decisions' output: ok when the round's
    decision line and every client row say ok and the robot was checked
    (not n/a) and right; False on a mismatch or a wrong robot; rounds
    without a decision line are left out."""
    rows = {}
    for line in lines:
        m = re.match(r'\s*(\d+) (.*)$', line)
        if m:
            rows.setdefault(int(m.group(1)), []).append(m.group(2))
    out = {}
    for n, texts in rows.items():
        decision = [t for t in texts if t.startswith('decision:')]
        robot = [t for t in texts if t.startswith('robot:')]
        if not decision:
            continue
        if any('MISMATCH' in t or 'ROBOT WRONG' in t for t in texts):
            out[n] = False
        elif decision[0].endswith('ok') and robot and \
                'n/a' not in robot[0]:
            out[n] = True
    return out


def report_rounds(summary):
    """{round: ok} of report's summary.json (cut-off rounds left out)."""
    out = {}
    for s in summary.get('sessions', []):
        for r in s.get('rounds', []):
            if not r.get('cut_off'):
                out[r['round']] = bool(r.get('ok'))
    return out


def run_verify(d, names):
    """verify_decisions on one chunk: {round: ok} and its status."""
    code, lines = run_tool(['rosrun', 'hri_sync', 'verify_decisions']
                           + names, 7200)
    with open(os.path.join(d, 'verify_decisions.txt'), 'w') as f:
        f.write('\n'.join(lines) + '\n')
    return {'status': code,
            'rounds': {str(n): v for n, v in verify_lines(lines).items()}}


def run_report(d, names):
    """report on one chunk: {round: ok} of its summary and its status."""
    code, lines = run_tool(['rosrun', 'hri_sync', 'report'] + names
                           + ['--out', os.path.join(d, 'report')], 7200)
    try:
        with open(os.path.join(d, 'report', 'summary.json')) as f:
            rounds = report_rounds(json.load(f))
    except (OSError, ValueError):
        rounds = {}
    return {'status': code, 'tail': lines[-3:],
            'rounds': {str(n): v for n, v in rounds.items()}}


TOOLS = {'verify': run_verify, 'report': run_report}


def check_chunk(out, k, parts, tool):
    """``tool`` (verify or report) on one chunk as one session, cached in
    OUT/chunks/K/TOOL.json: {parts, status, rounds: {round: ok}}."""
    d, names = chunk_dir(out, k, parts)
    cached = os.path.join(d, tool + '.json')
    key = [os.path.basename(p) for p in parts]
    if os.path.exists(cached):
        with open(cached) as f:
            result = json.load(f)
        if result['parts'] == key:
            return result
    t = time.time()
    result = dict(TOOLS[tool](d, names), parts=key,
                  seconds=round(time.time() - t, 1))
    sd.write_json(cached, result)
    return result


ONLY = None     # the chunk numbers to check (--chunks); None: all


def final_chunks(bags, finished):
    """(number, parts) of the chunks whose parts will not change: all of
    them once the run has finished, else those of the full size; only
    those of ONLY when set."""
    return [(k, c) for k, c in enumerate(chunks(bags))
            if (finished or len(c) == 3) and (ONLY is None or k in ONLY)]


def verify_all(out, bags, decided, finished, say, tools=('verify',
                                                         'report')):
    """Every decided round checked by verify_decisions and report in a
    chunk that holds it whole: the rounds each agreed with, and not."""
    out_ = {'chunks': len(chunks(bags))}
    for tool in tools:
        results = []
        for k, parts in final_chunks(bags, finished):
            say('%s, chunk %d: %s' % (tool, k, ', '.join(
                os.path.basename(p) for p in parts)))
            results.append(check_chunk(out, k, parts, tool))
        ok = {int(n) for r in results for n, v in r['rounds'].items() if v}
        bad = {int(n) for r in results for n, v in r['rounds'].items()
               if v is False} - ok
        out_[tool] = {'chunks_done': len(results),
                      'seconds': round(sum(r['seconds'] for r in results)),
                      'rounds_agreeing': len(ok & set(decided)),
                      'rounds_disagreeing': sorted(bad),
                      'decided_not_checked': len(set(decided) - ok - bad),
                      'met': bool(decided) and set(decided) <= ok}
    return out_


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
    fig, axes = plt.subplots(3, 1, figsize=(9, 7), sharex=True)
    for ax, key, label in ((axes[0], 'clock_agreement_ms',
                            'clock agreement, ms'),
                           (axes[1], 'decision_ms', 'decision latency, ms')):
        pts = [(r['end_s'] / 3600, r[key]) for r in rounds
               if r.get(key) is not None and r[key] > 0]
        ax.semilogy([p[0] for p in pts], [p[1] for p in pts], '.', ms=4)
        ax.set_ylabel(label)
    axes[2].plot([s['t_s'] / 3600 for s in samples],
                 [s['load_1min'] for s in samples], lw=1)
    axes[2].set_ylabel('load average (1 min)')
    axes[2].set_xlabel('hours since start (window end)')
    fig.tight_layout()
    fig.savefig(os.path.join(out, 'rounds.png'), dpi=100)
    plt.close('all')
    return [os.path.join(out, 'rss.png'), os.path.join(out, 'rounds.png')]


def analyze(out, tools=('verify', 'report'),
            say=lambda m: print(m, file=sys.stderr, flush=True)):
    """Everything above; the JSON (also written to OUT/analysis.json)."""
    with open(os.path.join(out, 'study_day.json')) as f:
        run = json.load(f)
    cfg = run['config']
    result = {'run_finished': run['finished'], 'summary': run['summary']}
    expected = cfg['rate_hz'] * cfg['dur_s']
    result['by_10_minutes'] = sd.by_window(
        [dict(r, frames_expected=expected) for r in run['rounds']],
        run['samples'], 600.0)
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
        decided = sorted(n for n, d in decisions.items()
                         if d.outcome != 'aborted')
        seen = [r['round'] for r in run['rounds'] if r.get('decided')]
        result['decisions_recorded_vs_seen'] = {
            'seen_live': len(seen), 'in_bags': len(decisions),
            'missing_from_bags': sorted(set(seen) - set(decisions))[:20]}
        result.update(verify_all(out, bags, decided, run['finished'], say,
                                 tools))
    sd.write_json(os.path.join(out, 'analysis.json'), result)
    return result


def watch(out, tools=('verify', 'report'), period=300.0,
          say=lambda m: print(m, file=sys.stderr, flush=True)):
    """Check the chunks as the run closes them (verify first), until the
    run has finished and every chunk is done; the last analysis."""
    while True:
        with open(os.path.join(out, 'study_day.json')) as f:
            finished = json.load(f)['finished']
        bags, _ = split_bags(out)
        for tool in tools:
            for k, parts in final_chunks(bags, finished):
                check_chunk(out, k, parts, tool)
                say('%s: chunk %d done' % (tool, k))
        if finished:
            return analyze(out, tools, say)
        time.sleep(period)
