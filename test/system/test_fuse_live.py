"""The live fusion node against fuse_bag on what it recorded.

The live fusion (fuse_bag_live.launch: three views of a dancer, the views
and the live fused body recorded by rosbag record, until the node has
fused LIVE_INSTANTS instants) against fuse_bag on that recording: the
same instants, most of them identical (92-98 % within 1 mm:
docs/fusion.md); the median instant within 1 mm.  And that recording
played into the live node under /use_sim_time (fuse_bag_replay.launch,
then rosbag play --clock once the node and the recorder listen): the same
instants, the median within 1 mm, every view and the people OK (not
behind), a REP 155 body for each fused skeleton.  A live node starved of
CPU skips instants and is then compared with fewer (below), so
scripts/run_rostests.py (make test, with the workspace sourced) runs
this test with nothing beside it:

run_rostests: alone
"""
import os
import signal
import subprocess
import time

import numpy as np
import pytest
import rosbag
import rosgraph

from hri_sync.fusion.associate import Associator
from hri_sync_support.fused_bags import POSES, fuse_bag
from hri_sync_support.harness import free_port, wait_for_master, wait_until

LIVE = os.path.join(os.path.dirname(os.path.abspath(__file__)),
                    'fuse_bag_live.launch')
REPLAY = os.path.join(os.path.dirname(os.path.abspath(__file__)),
                      'fuse_bag_replay.launch')
# Fused instants of the live fusion recorded; those compared are
# SETTLE s or more after its first and after each one it skipped (a node
# starved of CPU skips instants and goes on from a state the fusion of the
# recording afterwards, which fuses every one, does not share for a while:
# on a fresh clone's CI beside the other tests, 20-34 % of the instants in
# the 0.5 s after a skip within 1 mm of the fusion afterwards, 73-92 % of
# those 1-2 s after, 68-94 % later; unstarved, 92-98 % of all).
LIVE_INSTANTS = 360
SETTLE = 1.0
LIVE_SETTLED = 150     # settled instants the recording must hold
# s: a fusion that fused nothing for longer, while it heard from its
# views, no longer brings its person back (the association's
# resume_after, 3 s) and gives a new id where the fusion of the recording
# afterwards keeps one (3.8 s once, on CI; after a 2.7 s stop one id, 86 %
# of the settled instants within 1 mm): recorded again.
LIVE_STOP = Associator().resume_after
LIVE_TRIES = 3         # live recordings made before a starved fusion fails


def fused_by_instant(path):
    """{(instant on the 30 Hz grid, person): joints} of /fused/skeleton."""
    with rosbag.Bag(path) as bag:
        return {(round(m.header.stamp.to_sec() * 30), m.user_id):
                np.array([(p.x, p.y, p.z) for p in m.positions])
                for _, m, _ in bag.read_messages(topics=['/fused/skeleton'])}


def roslaunch(folder, name, launch, args, then):
    """``launch`` with ``args`` on a roscore of its own, its output in
    ``folder``/``name``.log; stopped once ``then(env, log)`` returns."""
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI='http://127.0.0.1:%d/' % port,
               ROS_HOME=str(folder), ROS_LOG_DIR=str(folder / 'log'))
    with open(folder / (name + '.log'), 'w') as log:
        master = subprocess.Popen(['rosmaster', '--core', '-p', str(port)],
                                  env=env, stdout=log,
                                  stderr=subprocess.STDOUT,
                                  start_new_session=True)
        procs = [master]
        try:
            wait_for_master(env['ROS_MASTER_URI'], 60.0)
            procs.insert(0, subprocess.Popen(
                ['roslaunch', launch] + args, env=env,
                stdout=log, stderr=subprocess.STDOUT, start_new_session=True))
            then(env, log)
        finally:
            for p in procs:
                if p.poll() is None:
                    os.killpg(p.pid, signal.SIGTERM if p is master
                              else signal.SIGINT)
                try:
                    p.wait(60)
                except subprocess.TimeoutExpired:
                    os.killpg(p.pid, signal.SIGKILL)
                    p.wait(60)
    return (folder / (name + '.log')).read_text()


def first_message(env, log, topic, timeout):
    """Wait for ``topic``'s first message (a node that starts slowly on a
    busy machine: the fusion's loads its profile)."""
    try:
        subprocess.run(['rostopic', 'echo', '-n', '1', topic], env=env,
                       stdout=subprocess.DEVNULL, stderr=log, check=True,
                       timeout=timeout)
    except subprocess.TimeoutExpired:
        pytest.fail('no %s in %.0f s' % (topic, timeout))


def fused_instants(env, log, folder, count, timeout):
    """Wait until the live fusion has published ``count`` fused instants
    (a starved node publishes fewer a second: the recording runs until it
    has them, not for a fixed time)."""
    path = folder / 'fused_stamps.csv'
    with open(path, 'w') as out:
        watch = subprocess.Popen(
            ['rostopic', 'echo', '-p', '/fused/skeleton/header/stamp'],
            env=env, stdout=out, stderr=log, start_new_session=True)

    def instants():
        return len({line.rsplit(',', 1)[-1] for line in
                    path.read_text().splitlines()[1:]})
    try:
        wait_until('%d fused instants' % count, lambda: instants() >= count,
                   timeout)
    except RuntimeError as e:
        pytest.fail('%s (the live fusion published %d)' % (e, instants()))
    finally:
        os.killpg(watch.pid, signal.SIGINT)
        watch.wait(60)
    time.sleep(1.0)         # the recorder's last ones


def subscribed(env, topics):
    """Whether every (topic, node) of ``topics`` is subscribed."""
    try:
        _, subs, _ = rosgraph.Master('/test_fuse_live',
                                     env['ROS_MASTER_URI']).getSystemState()
    except (OSError, rosgraph.MasterException):
        return False
    nodes = dict(subs)
    return all(node in nodes.get(topic, ()) for topic, node in topics)


def settled(instants):
    """Of the live fusion's instants (30 Hz grid numbers, sorted), those
    SETTLE s or more after its first and after each one it skipped."""
    since, kept = instants[0], []
    for a, b in zip([instants[0] - 1] + instants, instants):
        if b - a > 1:
            since = b
        if b - since >= SETTLE * 30:
            kept.append(b)
    return kept


@pytest.fixture(scope='module')
def live(tmp_path_factory):
    """A recording of the live fusion (fuse_bag_live.launch) and its
    /fused/skeleton by instant, the settled instants only (above); one
    with fewer than LIVE_SETTLED is recorded again, up to LIVE_TRIES
    times."""
    tries = []
    for _ in range(LIVE_TRIES):
        folder = tmp_path_factory.mktemp('live')
        recording = str(folder / 'live.bag')

        def record(env, log):
            wait_until('the recording', lambda: os.path.exists(
                recording + '.active'), 120.0)
            first_message(env, log, '/fused/skeleton', 120.0)
            fused_instants(env, log, folder, LIVE_INSTANTS, 120.0)
        log = roslaunch(folder, 'live', LIVE, ['bag:=' + recording], record)
        assert os.path.exists(recording), log
        by_instant = fused_by_instant(recording)
        instants = sorted({t for t, _ in by_instant})
        kept = set(settled(instants))
        stop = max(np.diff(instants), default=1) / 30.0
        tries.append('%d instants, %.1f %% of its span, %d settled, '
                     'longest stop %.2f s'
                     % (len(instants), 100 * len(instants)
                        / (instants[-1] - instants[0] + 1), len(kept), stop))
        print('live fusion: %s' % tries[-1])
        if len(kept) >= LIVE_SETTLED and stop <= LIVE_STOP:
            return folder, recording, {k: v for k, v in by_instant.items()
                                       if k[0] in kept}
    pytest.fail('the live fusion skipped instants (starved of CPU) in each '
                'of %d recordings: %s' % (LIVE_TRIES, '; '.join(tries)))


def people_said(path):
    """The fusion's people statuses in the recording other than OK."""
    with rosbag.Bag(path) as bag:
        return sorted({s.message for _, m, _ in bag.read_messages(
            ['/diagnostics']) for s in m.status
            if s.level and s.name.endswith('people')})


def compare(live, again, recording):
    """The share of ``live``'s instants ``again`` gives within 1 mm and
    their median difference (m); one person, as the live fusion said
    (``recording``: its /diagnostics)."""
    spans = {pid: (min(t for t, p in live if p == pid) / 30,
                   max(t for t, p in live if p == pid) / 30)
             for pid in {k[1] for k in live}}
    assert {k[1] for k in live} == {k[1] for k in again} == {1}, (
        'live: %s (person: first, last instant); again: %s; the live '
        'fusion said %s' % (spans, sorted({k[1] for k in again}),
                            people_said(recording)[:3]))
    common = sorted(set(live) & set(again))
    assert len(common) >= 0.9 * len(live), 'live instants missing: %s' % (
        sorted(k[0] for k in set(live) - set(again)))
    diff = [np.abs(live[k] - again[k]).max() for k in common]
    print('%d live instants, %d fused again, %d common: %.1f %% within '
          '1 mm, max %.3f m' % (len(live), len(again), len(common),
                                100 * np.mean(np.less(diff, 1e-3)),
                                max(diff)))
    return np.mean(np.less(diff, 1e-3)), np.median(diff)


def test_fuse_bag_fuses_a_live_recording_as_the_live_node_did(live):
    folder, recording, by_instant = live
    out = str(folder / 'offline.bag')
    run = fuse_bag(recording, '--out', out, '--poses', str(POSES))
    assert run.returncode == 0, run.stdout + run.stderr
    _, median = compare(by_instant, fused_by_instant(out), recording)
    assert median < 1e-3


def test_the_recording_played_into_the_live_node_under_sim_time(live):
    # rosbag play --clock into fusion.launch with /use_sim_time: the node
    # runs on the played clock, so its skeletons are on time (never WARN
    # behind), and it fuses them as it did live; its REP 155 bodies
    # (rep155_bridge) come with every fused skeleton. Under load a view's
    # skeletons may reach the node a moment after the played clock (a
    # view then reads stalled), so the views are OK in most statuses, not
    # in every one.
    folder, recording, by_instant = live
    out = str(folder / 'replayed.bag')
    played = ['/%s/%s' % (v, t) for v in POSES
              for t in ('skeleton', 'clock_state')]

    def play(env, log):
        # The node and the recorder listening first, then the recording
        # played on its own clock: after each topic's advertisement a
        # second for the node to connect (the first skeletons are not
        # lost), at a quarter of its speed (on a busy machine the node
        # keeps up with the played clock and skips no instant: at half,
        # one CI run's node skipped some).
        wait_until('the fusion and the recorder', lambda: subscribed(
            env, [(t, '/fused/fusion') for t in played]
            + [('/fused/skeleton', '/recorder'), ('/tf', '/recorder')]),
            120.0)
        subprocess.run(['rosbag', 'play', '--clock', '-d', '1', '-r', '0.25',
                        recording, '--topics'] + played, env=env, stdout=log,
                       stderr=subprocess.STDOUT, check=True, timeout=300)
        time.sleep(2.0)

    log = roslaunch(folder, 'replay', REPLAY, ['out:=' + out], play)
    assert os.path.exists(out), log
    again = fused_by_instant(out)
    _, median = compare(by_instant, again, recording)
    assert median < 1e-3
    statuses, tf = {}, 0
    with rosbag.Bag(out) as bag:
        for topic, msg, _ in bag.read_messages(['/diagnostics', '/tf']):
            if topic == '/tf':
                tf += any(t.child_frame_id == 'body_fused1'
                          for t in msg.transforms)
                continue
            for s in msg.status:
                statuses.setdefault(s.name.split(': ')[-1], []).append(s)
    assert tf >= 0.9 * len(again)
    assert not [s.message for s in statuses['people']
                if 'behind' in s.message]
    for name in ('view left', 'view right', 'view back', 'people'):
        ok = [s.level == 0 for s in statuses[name]]
        assert sum(ok) >= 0.75 * len(ok), (name, [
            s.message for s in statuses[name] if s.level])
