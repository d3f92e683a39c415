"""The pure parts of bench/study_day.py: /proc parsing, node names, the
first-vs-last window comparisons, RSS growth, frames across bag splits."""
import math
import os
import random
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(
    os.path.dirname(os.path.abspath(__file__)))), 'bench'))
import study_day as sd  # noqa: E402

STATUS = """Name:\tpython3
Umask:\t0022
State:\tS (sleeping)
VmPeak:\t  612340 kB
VmHWM:\t   58120 kB
VmRSS:\t   56508 kB
Threads:\t9
"""


def test_parse_vm_reads_rss_and_hwm():
    assert sd.parse_vm(STATUS) == 56508
    assert sd.parse_vm(STATUS, 'VmHWM') == 58120


def test_parse_vm_of_a_kernel_thread_is_none():
    assert sd.parse_vm('Name:\tkthreadd\nState:\tS\n') is None


def test_node_key_from_the_ros_log_name():
    cmd = ['/usr/bin/python3', '/ws/devel/lib/hri_sync/data_process_module',
           '__name:=dpm', '__log:=/root/.ros/log/abc/c3-dpm-12.log']
    assert sd.node_key(cmd) == 'c3-dpm'


def test_node_key_without_a_log():
    assert sd.node_key(['rosout', '__name:=rosout']) == 'rosout'
    assert sd.node_key(['/usr/bin/python3', '/usr/bin/roslaunch', '--wait',
                        'hri_sync', 'client.launch', 'client_id:=c4']) \
        == 'roslaunch[c4]'
    assert sd.node_key(['chronyd', '-x', '-d']) == 'chronyd'
    assert sd.node_key([]) == '?'


def test_unique_keys_numbers_repeats():
    assert sd.unique_keys(['a', 'b', 'a', 'a']) == ['a', 'b', 'a#2', 'a#3']


def test_percentile_interpolates_and_ignores_missing():
    xs = list(range(101))
    random.Random(3).shuffle(xs)
    assert sd.percentile(xs + [None, math.nan], 99) == 99
    assert sd.percentile([1.0, 2.0], 50) == 1.5
    assert math.isnan(sd.percentile([], 99))


def test_within_relative_change():
    assert sd.within(100.0, 109.0, 0.1)['met'] is True
    assert sd.within(100.0, 111.0, 0.1)['met'] is False
    assert sd.within(100.0, 50.0, 0.1)['met'] is True     # better
    assert sd.within(None, 5.0, 0.1)['met'] is None


def rounds_with(first, last, n=10, total=7200.0):
    """Rounds at the start (value ``first``) and the end (``last``)."""
    rows = [{'end_s': 60.0 * i, 'x': first} for i in range(1, n)]
    rows += [{'end_s': total - 60.0 * i, 'x': last} for i in range(n)]
    rows.append({'end_s': 3600.0, 'x': 1e6})      # the middle: not compared
    rows.append({'end_s': 100.0, 'x': None})      # no figure
    return rows


def test_compare_windows_within_20_percent():
    out = sd.compare_windows(rounds_with(1.0, 1.15), 'x', 600.0, 7200.0)
    assert out['met'] is True and out['first'] == 1.0
    assert out['rounds'] == [9, 10]


def test_compare_windows_grown_past_20_percent():
    out = sd.compare_windows(rounds_with(1.0, 1.3), 'x', 600.0, 7200.0)
    assert out['met'] is False and abs(out['change'] - 0.3) < 1e-9


def test_compare_windows_without_rounds():
    assert sd.compare_windows([], 'x', 600.0, 7200.0)['met'] is None


def sample(t, rss, pid=None):
    return {'t_s': t, 'rss_kb': rss, 'pid': pid or {k: 1 for k in rss},
            'cpu_s': {}, 'load_1min': 1.0}


def test_rss_growth_against_the_first_10_minutes():
    samples = [sample(0, {'a': 50000, 'b': 40000}),
               sample(600, {'a': 60000, 'b': 40000}),
               sample(7200, {'a': 65000, 'b': 48000})]
    out = sd.rss_growth(samples, 600)
    assert out['a']['met'] is True         # +8 %
    assert out['b']['met'] is False        # +20 %
    assert sd.rss_growth(samples[:1], 600) == {}


def test_restarts_count_pid_changes():
    samples = [sample(0, {'a': 1}, {'a': 10, 'b': 11}),
               sample(60, {'a': 1}, {'a': 12, 'b': 11}),
               sample(120, {'a': 1}, {'a': 12})]
    assert sd.restarts(samples) == {'pid_changes': {'a': 1}, 'gone': ['b']}


def test_restarts_leave_out_the_launch_starting():
    samples = [sample(0, {'a': 1}, {'roslaunch': 9}),
               sample(60, {'a': 1}, {'a': 12}),
               sample(120, {'a': 1}, {'a': 12})]
    assert sd.restarts(samples)['gone'] == ['roslaunch']
    assert sd.restarts(samples, 30.0) == {'pid_changes': {}, 'gone': []}


def test_clock_spread():
    assert sd.clock_spread({'c1': 0.6, 'c2': 0.75, 'c3': 0.55}) == \
        0.75 - 0.55
    assert sd.clock_spread({'c1': 0.6}) is None


def test_frames_in_a_window_across_a_split():
    rng = random.Random(7)
    stamps = sorted(100.005 + i * 0.01 + rng.uniform(-1e-3, 1e-3)
                    for i in range(6000))
    assert sd.count_in_window(stamps, 110.0, 130.0) == 2000
    assert sd.straddles(110.0, 130.0, [105.0, 120.0, 131.0]) == [120.0]


def test_speeds_are_four_positive_numbers():
    assert sd.parse_speeds('1.0, 0.3,1,0.6') == ('1.0', '0.3', '1', '0.6')
    for bad, says in (('1,2,3', '3 speeds given'), ('1,2,3,0', "'0'"),
                      ('1,2,x,4', "'x'"), ('1,2,3,nan', "'nan'"),
                      ('1,2,3,4,5', '5 speeds given')):
        try:
            sd.parse_speeds(bad)
        except ValueError as e:
            assert says in str(e), (bad, e)
        else:
            raise AssertionError(bad)


def test_the_launch_gives_each_client_its_speed():
    from types import SimpleNamespace
    opts = SimpleNamespace(port=11411, ntp_port=11497, dur=60.0, rate=100.0,
                           split_minutes=10, out='/tmp/sd',
                           speeds=('1.0', '0.3', '0.5', '0.6'))
    text = sd.launch_text(opts, '/tmp/sd/bags/session')
    speeds = [line.split('"')[3] for line in text.splitlines()
              if 'name="speed"' in line]
    assert speeds == ['1.0', '0.3', '0.5', '0.6']


import study_day_analysis as sda  # noqa: E402


def test_chunks_overlap_so_every_split_is_inside_one():
    parts = ['p%d' % i for i in range(8)]
    got = sda.chunks(parts)
    assert got == [['p0', 'p1', 'p2'], ['p2', 'p3', 'p4'],
                   ['p4', 'p5', 'p6'], ['p6', 'p7']]
    inside = {(c[i], c[i + 1]) for c in got for i in range(len(c) - 1)}
    assert inside == {(parts[i], parts[i + 1]) for i in range(7)}
    assert sda.chunks(['p0']) == [['p0']]
    assert sda.final_chunks(parts, False) == list(enumerate(got[:3]))
    sda.ONLY = {1, 3}
    assert sda.final_chunks(parts, True) == [(1, got[1]), (3, got[3])]
    sda.ONLY = None


VERIFY = """x.bag .. chunk_3.bag (4 split parts): 3 decisions
x.bag .. chunk_3.bag (4 split parts): round 9: CUT OFF: it began
round client   status   frames(rec/re)  value recorded   recomputed  check
    7 c1       ok         5000/5000         38.6832514       38.6832514  ok
    7 decision: recorded winner (participant 1), recomputed winner  ok
    8 c1       ok         5000/4999         38.6832514       38.6832514  \
MISMATCH: frames 5000 recorded, 4999 recomputed
    8 decision: recorded winner (participant 1), recomputed winner  ok
    6 c1       ok         10/5000         1.0       2.0  MISMATCH: no
    6 decision: recorded winner (participant 1), recomputed winner  ok
robot: participants at +45.0, +15.0 deg
    7 robot: expected to face participant 1: robot faced participant 1
    8 robot: expected to face participant 1: robot faced participant 1
    6 robot: expected to face participant 1: robot: n/a (the recording)
"""


def test_verify_lines_reads_each_rounds_verdict():
    assert sda.verify_lines(VERIFY.splitlines()) == {7: True, 8: False,
                                                     6: False}


def test_report_rounds_leave_out_cut_off_rounds():
    summary = {'sessions': [{'rounds': [
        {'round': 1, 'cut_off': False, 'ok': True},
        {'round': 2, 'cut_off': True, 'ok': False},
        {'round': 3, 'cut_off': False, 'ok': False}]}]}
    assert sda.report_rounds(summary) == {1: True, 3: False}


class Stamp:
    def __init__(self, t):
        self.t = t

    def to_sec(self):
        return self.t


class Result:
    def __init__(self, start, end, frames):
        self.capture_start, self.capture_end = Stamp(start), Stamp(end)
        self.frames, self.frames_rejected = frames, 0


def test_frames_across_splits_counts_the_bags_against_the_results():
    stamps = {'c1': [10.005 + 0.01 * i for i in range(3000)]}
    results = {(1, 'c1'): Result(10.0, 20.0, 1000),
               (2, 'c1'): Result(20.0, 30.0, 1000),
               (3, 'c1'): Result(30.0, 40.0, 1001)}
    out = sda.frames_across_splits(stamps, results, [25.0], 100.0)
    assert out['windows'] == 3 and out['windows_across_a_split'] == 1
    assert out['frames_lost'] == 1 and not out['met']
    assert [r['round'] for r in out['windows_missing_frames']] == [3]


def test_by_window_splits_the_run_by_window_end():
    rounds = [{'end_s': 100.0, 'clock_agreement_ms': 0.1, 'decision_ms': 50,
               'frames': {'c1': 90}, 'frames_expected': 100},
              {'end_s': 500.0, 'clock_agreement_ms': 0.3, 'decision_ms': 70,
               'frames': {'c1': 100}, 'frames_expected': 100},
              {'end_s': 1300.0, 'clock_agreement_ms': 2.0,
               'decision_ms': 90, 'frames': {}, 'frames_expected': 100},
              {'end_s': None}]
    samples = [{'t_s': 0.0, 'load_1min': 2.0}, {'t_s': 300.0,
                                               'load_1min': 4.0}]
    out = sd.by_window(rounds, samples, 600.0)
    assert [w['rounds'] for w in out] == [2, 0, 1]
    assert out[0]['clock_p50_ms'] == 0.2 and out[0]['load_mean'] == 3.0
    assert out[0]['frames_min_share'] == 0.9
    assert out[1]['clock_p99_ms'] is None and out[2]['decision_p50_ms'] == 90
