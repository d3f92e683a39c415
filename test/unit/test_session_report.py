"""The session report and verify_decisions on recorded sessions.

test/bags/session_robot.bag (2 rounds, winner 1) and session_still.bag
(1 round, no_winner, raw sensor streams) are whole dance-off sessions
with DJ Rob and the music (scripts/make_session_bags.py); variants are
made from them here (edited scores, a robot turned wrong, topics left
out).  session_robot.bag was recorded before the timestamped messages got
a std_msgs/Header, session_still.bag after: the tools read both.
"""
import base64
import csv
import io
import json
import math
import os
import re
from types import SimpleNamespace

import pytest

pytest.importorskip('rosbags', reason='rosbags is installed by make venv')
pytest.importorskip('matplotlib', reason='python3-matplotlib (make setup)')

import matplotlib.image  # noqa: E402

import bag_edit  # noqa: E402
from hri_sync_support.harness import run_script  # noqa: E402
from hri_sync.tools import report  # noqa: E402
from hri_sync.tools.bag import BagError  # noqa: E402

ROOT = os.path.join(os.path.dirname(__file__), '..', '..')
BAGS = os.path.join(ROOT, 'test', 'bags')
ROBOT = os.path.join(BAGS, 'session_robot.bag')
STILL = os.path.join(BAGS, 'session_still.bag')


def quiet(*_):
    pass


@pytest.fixture(scope='module')
def built(tmp_path_factory):
    out = str(tmp_path_factory.mktemp('report'))
    rep = report.build([ROBOT, STILL], out, export_csv=True, rate=25.0,
                       say=quiet)
    return out, rep


def images(page):
    return re.findall(r'<img id="([^"]+)" alt="[^"]*" '
                      r'src="data:image/png;base64,([^"]+)">', page)


def test_every_plot_is_embedded_and_decodes(built):
    out, rep = built
    with open(os.path.join(out, 'index.html')) as f:
        page = f.read()
    imgs = images(page)
    assert len(imgs) == page.count('<img')
    figures = [f['id'] for s in rep['sessions'] for f in s['figures']]
    assert sorted(i for i, _ in imgs) == sorted(figures)
    # clocks, rounds, heading and one per round, for each session
    assert len(figures) == (3 + 2) + (3 + 1)
    for _, data in imgs:
        png = base64.b64decode(data, validate=True)
        assert png.startswith(b'\x89PNG\r\n\x1a\n')
        pixels = matplotlib.image.imread(io.BytesIO(png), format='png')
        assert pixels.shape[0] > 100 and pixels.shape[1] > 300
        assert pixels.std() > 0.01          # not a blank image
    assert 'http://' not in page and 'https://' not in page


def test_summary_holds_what_the_page_shows(built):
    out, rep = built
    with open(os.path.join(out, 'summary.json')) as f:
        summary = json.load(f)          # strict JSON: no NaN
    assert summary == json.loads(json.dumps(rep))
    robot, still = summary['sessions']
    assert robot['totals']['rounds'] == 2
    assert robot['totals']['reproduced'] == 2
    assert robot['totals']['robot_ok'] == 2
    assert robot['totals']['ok'] and still['totals']['ok']
    assert still['rounds'][0]['decision']['outcome'] == 'no_winner'
    assert still['rounds'][0]['robot']['expected'] == 'stay still'
    with open(os.path.join(out, 'index.html')) as f:
        page = f.read()
    for s in summary['sessions']:
        for r in s['rounds']:
            assert r['verdict'] in page
            for c, v in r['clients'].items():
                # Figure 5's first tick is the result's first frame.
                assert r['fig5'][c][0] == pytest.approx(
                    v['first_frame_offset_ms'], abs=1e-3)
                assert '%.1f' % v['first_frame_offset_ms'] in page
                # The build-up ends at the recorded score.
                assert r['build_up'][c]['value'][-1] == pytest.approx(
                    v['value'], rel=1e-6)
            assert '%.3f' % r['start_skew_ms'] in page
            assert 0 <= r['start_skew_ms'] < 50
            assert r['error_bound_ms'] is None or r['error_bound_ms'] >= 0
            assert r['ack_round_ms'] > 0
            assert set(r['starts']) == {'dance', 'music'}
        for client, series in s['clocks'].items():
            assert len(series['t']) == len(series['round_trip_ms'])
            assert all(rt is None or 0 < rt < 100
                       for rt in series['round_trip_ms'])
    # The still session recorded the raw streams: frames before the start.
    raw = still['rounds'][0]['fig5_raw']
    assert set(raw) == {'left', 'right'}
    assert all(min(ticks) < 0 for ticks in raw.values())


def test_export_csv_aligns_both_participants(built):
    out, rep = built
    s = rep['sessions'][0]
    with open(s['export']['aligned']) as f:
        rows = list(csv.DictReader(f))
    with open(s['export']['raw']) as f:
        raw = list(csv.DictReader(f))
    dur = s['rounds'][0]['dur']
    per_round = int(round(dur * 25.0))
    assert len(rows) == 2 * per_round
    r1 = [r for r in rows if r['round'] == '1']
    step = [float(b['t_window']) - float(a['t_window'])
            for a, b in zip(r1, r1[1:])]
    assert all(x == pytest.approx(0.04, abs=1e-6) for x in step)
    frames = sum(v['frames'] + v['rejected'] for r in s['rounds']
                 for v in r['clients'].values())
    assert len(raw) == frames
    # A grid point between two raw samples is their interpolation.
    left = [r for r in raw if r['client'] == 'left' and r['round'] == '1']
    t = [float(r['stamp']) for r in left]
    x = [float(r['head_x']) for r in left]
    k = len(r1) // 2
    g = float(r1[k]['stamp'])
    i = max(j for j in range(len(t)) if t[j] <= g)
    want = x[i] + (x[i + 1] - x[i]) * (g - t[i]) / (t[i + 1] - t[i])
    assert float(r1[k]['left_head_x']) == pytest.approx(want, abs=1e-6)
    assert r1[k]['right_head_x'] != ''


def drop_topics(src, dst, prefixes):
    bag_edit.copy_bag(src, dst, lambda topic, t, m: None if any(
        topic.startswith(p) or topic.endswith(p) for p in prefixes) else m)


def test_missing_topics_are_named_and_the_rest_rendered(tmp_path):
    cut = str(tmp_path / 'cut.bag')
    drop_topics(ROBOT, cut, ['/odom', '/mobile_base', 'clock_state',
                             '/dj_rob/action_start', '/music/action_start'])
    out = str(tmp_path / 'out')
    rep = report.build([cut], out, say=quiet)
    s = rep['sessions'][0]
    missing = {m['section']: m['reason'] for m in s['missing']}
    assert 'DJ Rob: heading and gesture' in missing
    assert '/odom' in missing['DJ Rob: heading and gesture']
    assert 'Clocks: offset, drift, uncertainty' in missing
    assert 'NTP round trips' in missing
    assert 'DJ Rob and music: start against the schedule' in missing
    assert s['totals']['reproduced'] == 2
    with open(os.path.join(out, 'index.html')) as f:
        page = f.read()
    assert 'Not in this recording' in page and '/odom' in page
    assert len(images(page)) == 1 + 2       # rounds overview, 2 rounds


def test_no_bag_readable_is_an_error(tmp_path):
    empty = tmp_path / 'empty.bag'
    empty.write_bytes(b'')
    with pytest.raises(BagError, match='empty'):
        report.build([str(empty)], str(tmp_path / 'out'), say=quiet)
    assert not os.path.exists(tmp_path / 'out' / 'index.html')
    rep = report.build([str(empty), STILL], str(tmp_path / 'out'),
                       say=quiet)
    assert len(rep['errors']) == 1 and 'empty' in rep['errors'][0]
    assert len(rep['sessions']) == 1


def run(tool, *args):
    """nodes/TOOL ARGS, in this process: .returncode, .stdout."""
    code, out = run_script(os.path.join(ROOT, 'nodes', tool), args)
    return SimpleNamespace(returncode=code, stdout=out)


def test_verify_decisions_agrees_on_a_whole_session():
    out = run('verify_decisions', ROBOT, STILL)
    assert out.returncode == 0, out.stdout
    assert out.stdout.count('robot faced participant 1') == 2
    assert 'robot did not move, as it should on no_winner' in out.stdout
    assert 'all 2 rounds agree' in out.stdout
    assert 'all 1 rounds agree' in out.stdout


def edit_first(topic_name, change):
    """An edit that changes the first message on ``topic_name``."""
    done = []

    def edit(topic, t, msg):
        if topic == topic_name and not done:
            change(msg)
            done.append(t)
        return msg
    return edit


def test_verify_decisions_fails_on_an_edited_score(tmp_path):
    edited = str(tmp_path / 'edited.bag')
    bag_edit.copy_bag(ROBOT, edited, edit_first(
        '/client_result', lambda m: setattr(m, 'value', m.value * 1.01)))
    out = run('verify_decisions', edited)
    assert out.returncode == 1, out.stdout
    assert 'MISMATCH' in out.stdout and 'DISAGREEMENT in round(s) 1' \
        in out.stdout

    def swap_scores(m):
        m.scores = m.scores[::-1].copy()
    edited2 = str(tmp_path / 'edited2.bag')
    bag_edit.copy_bag(ROBOT, edited2, edit_first('/decision', swap_scores))
    out = run('verify_decisions', edited2)
    assert out.returncode == 1, out.stdout
    assert 'decision score of left' in out.stdout


def turned_odometry(src, dst, after_ns, degrees):
    """Rotate every odometry pose after ``after_ns`` by ``degrees``."""
    a = math.radians(degrees) / 2

    def edit(topic, t, msg):
        if topic == '/odom' and t > after_ns:
            q = msg.pose.pose.orientation
            c, s = math.cos(a), math.sin(a)
            q.w, q.x, q.y, q.z = (c * q.w - s * q.z, c * q.x - s * q.y,
                                  c * q.y + s * q.x, c * q.z + s * q.w)
        return msg
    bag_edit.copy_bag(src, dst, edit)


def decision_times(path):
    from rosbags.rosbag1 import Reader
    with Reader(path) as r:
        conns = [c for c in r.connections if c.topic == '/decision']
        return [t for _, t, _ in r.messages(conns)]


def test_verify_decisions_fails_on_a_robot_that_turned_wrong(tmp_path):
    wrong = str(tmp_path / 'wrong.bag')
    first, second = decision_times(ROBOT)
    turned_odometry(ROBOT, wrong, second, -25.0)  # round 2's gesture on
    out = run('verify_decisions', wrong)
    assert out.returncode == 1, out.stdout
    assert 'ROBOT WRONG' in out.stdout and 'off by 25.0 deg' in out.stdout
    assert 'recomputed winner (participant 1)  ok' in out.stdout
    assert run('verify_decisions', '--heading-tolerance', '30',
               wrong).returncode == 0


def test_verify_decisions_fails_on_a_robot_moving_without_winner(tmp_path):
    moved = str(tmp_path / 'moved.bag')
    # From 0.25 s after the decision: decisions now come within ~0.1 s of
    # the window's end, and robot_check takes its reference pose at the
    # end + AFTER_WINDOW_SLACK (0.2 s), which a step turned with the
    # decision would move too.
    turned_odometry(STILL, moved, decision_times(STILL)[0] + 250000000,
                    15.0)
    out = run('verify_decisions', moved)
    assert out.returncode == 1, out.stdout
    assert 'it moved: up to 0.000 m and 15.0 deg' in out.stdout


def test_tools_on_a_killed_recording(tmp_path):
    from rosbags.rosbag1 import Reader
    with Reader(ROBOT) as r:
        conns = [c for c in r.connections if c.topic == '/capture_data']
        cut = [t for _, t, _ in r.messages(conns)][1] + 10 ** 9
    bag_edit.write_unclosed(ROBOT, str(tmp_path / 'k.bag.active'), cut)
    bag = str(tmp_path / 'k.bag')
    out = run('verify_decisions', bag)
    assert out.returncode == 2
    assert 'rosbag reindex' in out.stdout and '--reindex' in out.stdout
    out = run('report', bag, '--out', str(tmp_path / 'r'))
    assert out.returncode != 0 and 'rosbag reindex' in out.stdout
    out = run('verify_decisions', '--reindex', bag)
    assert out.returncode == 0, out.stdout
    assert 'round 2: CUT OFF' in out.stdout
    out = run('report', bag, '--out', str(tmp_path / 'r'))
    assert out.returncode == 0, out.stdout   # listed, not checked
    assert 'round 2: CUT OFF' in out.stdout
    with open(tmp_path / 'r' / 'summary.json') as f:
        assert json.load(f)['sessions'][0]['totals']['cut_off'] == [2]


def test_report_cli_names_an_old_message_version(tmp_path):
    old = str(tmp_path / 'old.bag')
    bag_edit.copy_bag(STILL, old, md5={
        'hri_sync/Decision': 'ffffffffffffffffffffffffffffffff'})
    out = run('report', old, '--out', str(tmp_path / 'r'))
    assert out.returncode == 2
    assert 'hri_sync/Decision has md5 ffffffffffffffffffffffffffffffff' \
        in out.stdout
    out = run('report', old, '--allow-old-messages', '--out',
              str(tmp_path / 'r'))
    assert out.returncode == 0, out.stdout


def test_error_bound_when_the_messages_carry_it():
    from hri_sync.tools import analysis
    from hri_sync.tools.bag import read_bag
    from hri_sync.tools.session import build_session
    c = read_bag(STILL)
    s = analysis.summarize(build_session(c))
    r = s['rounds'][0]                      # recorded with issue 10's bound
    bounds = [v['error_bound_ms'] for v in r['clients'].values()]
    assert len(bounds) == 2 and all(0 <= b < 5 for b in bounds)
    assert r['error_bound_ms'] == pytest.approx(max(bounds))
    assert 'Error bound' not in {m['section'] for m in s['missing']}
    c.messages['/decision'][0].msg.timing_uncertainty = math.nan
    for r, bound in zip(c.messages['/client_result'], (0.0004, 0.0007)):
        r.msg.timing_uncertainty = bound
    s = analysis.summarize(build_session(c))
    r = s['rounds'][0]
    assert sorted(v['error_bound_ms'] for v in r['clients'].values()) == \
        pytest.approx([0.4, 0.7])
    assert r['error_bound_ms'] == pytest.approx(0.7)   # the worst result
    c.messages['/decision'][0].msg.error_bound = 0.0009
    s = analysis.summarize(build_session(c))
    assert s['rounds'][0]['error_bound_ms'] == pytest.approx(0.9)
    assert 'Error bound' not in {m['section'] for m in s['missing']}
    assert s['totals']['error_bound_ms']['p99'] == pytest.approx(0.9)


def test_results_past_the_deadline_are_not_held_against_the_decision():
    # As in a loaded campaign run: both DPMs published after the decision
    # module's deadline, which aborted the round ("missing").
    from hri_sync.tools import analysis
    from hri_sync.tools.bag import read_bag
    from hri_sync.tools.session import build_session
    c = read_bag(ROBOT)
    d = c.messages['/decision'][1]
    d.msg.outcome, d.msg.winner = 'aborted', 0
    d.msg.scores = d.msg.scores * float('nan')
    for r in c.messages['/client_result']:
        if r.msg.round == 2:
            r.t = d.t + 0.8
    s = analysis.summarize(build_session(c))
    r2 = s['rounds'][1]
    assert r2['recomputed']['reproduced'], r2['recomputed']
    assert r2['recomputed']['late_results_s'] == pytest.approx(
        {'left': 0.8, 'right': 0.8})
    assert 'recorded 0.80 s, 0.80 s after the decision' in r2['verdict']
    # A score in the decision means the DM had that result: not late.
    d.msg.scores[0] = 1.0
    s = analysis.summarize(build_session(c))
    assert s['rounds'][1]['recomputed']['late_results_s'] == \
        pytest.approx({'right': 0.8})
    assert not s['rounds'][1]['recomputed']['reproduced']


def test_a_session_that_is_not_a_dance_off_reads_without_false_failures():
    """A generic sensor's session: its captured frames are named, not
    called missing, and its decisions are not recomputed rather than
    '0/2 reproduced'."""
    from hri_sync.tools.analysis import missing_sections, reproduced_text
    from hri_sync.tools.session import Session
    s = Session('scan.bag', {'/scan/captured': 'sensor_msgs/LaserScan',
                             '/decision': 'hri_sync/Decision'})
    reasons = {m['section']: m['reason'] for m in missing_sections(s)}
    fig5 = [r for k, r in reasons.items() if k.startswith('Figure 5')][0]
    assert fig5 == ('not a dance-off: its captured frames are not skeletons '
                    '(/scan/captured (sensor_msgs/LaserScan))')
    assert not any('issue' in r or 'no the' in r for r in reasons.values())
    t = {'decided': 2, 'reproduced': 0, 'recomputed': 0}
    assert reproduced_text(t) == ('decisions not recomputed (no captured '
                                  'skeleton frames)')
    assert reproduced_text(dict(t, reproduced=1, recomputed=2)) == \
        '1/2 decisions reproduced'


def test_a_round_begun_before_a_later_part_is_cut_off_not_failed(tmp_path):
    # The second part of a split recording starts inside round 2's window:
    # its decision and results are there, not all its frames.
    from test_tools_bag import split_in_two
    parts = split_in_two(tmp_path)
    later = report.build([parts[1]], str(tmp_path / 'later'), say=quiet)
    rounds = {r['round']: r for r in later['sessions'][0]['rounds']}
    assert rounds[2]['cut_off'] == 'start' and not rounds[2]['ok']
    assert 'began before the recording' in rounds[2]['verdict']
    assert later['sessions'][0]['totals']['cut_off'] == [2]
    # listed, not checked: no failure of the recording (report exits 0)
    assert rounds[2]['ok'] is None and later['sessions'][0]['totals']['ok']
    out = run('verify_decisions', parts[1])
    assert out.returncode == 0, out.stdout
    assert 'round 2: CUT OFF: its window began before the recording' \
        in out.stdout
    assert 'no round wholly in this recording' in out.stdout
    # with a bag of the config (recorded at the start) before it, as
    # bench/study_day.py checks a later chunk: the rounds still begin late
    cfg, late = str(tmp_path / 'c_0.bag'), str(tmp_path / 'c_1.bag')
    bag_edit.copy_bag(ROBOT, cfg, edit=lambda topic, _t, m: m if topic in (
        'dance_off/config', '/dance_off/config') else None)
    os.symlink(parts[1], late)
    out = run('verify_decisions', cfg, late)
    assert 'round 2: CUT OFF: its window began before the recording' \
        in out.stdout, out.stdout
    whole = report.build(parts, str(tmp_path / 'whole'), say=quiet)
    assert [r['cut_off'] for r in whole['sessions'][0]['rounds']] \
        == [False, False]
    assert all(r['ok'] for r in whole['sessions'][0]['rounds'])
