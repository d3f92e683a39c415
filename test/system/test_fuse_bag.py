"""fuse_bag: a recording of three views fused afterwards.

Writes a bag as ``rosbag record`` would have on a host whose clock is
0.3 s behind the global clock (its ClockState says so): three views of
data/motion/cmu_60_01_salsa.track at 30 Hz from their poses, 1 cm noise,
each skeleton recorded 50-80 ms after its capture, the back view stalled
from 6 s on.  Runs ``fuse_bag`` on it (no roscore) and checks what it
wrote: a fused person on the 30 Hz grid of the global clock, near the
motion, from all three views until the stall and two after, recorded
after the newest capture it used; the back view's diagnostics ERROR
``stalled`` at the end; that with --labels-from-later it writes the same
instants, each skeleton as before or with its sides exchanged as it
says, and the instants the look-ahead relabels are the ones written so;
and that a bad setting, views the bag lacks and a missing bag each give
a clear error and exit status.  The live fusion node against fuse_bag:
test_fuse_live.py.  Run by scripts/run_rostests.py (make test) with the
workspace sourced.
"""
import math
import os
import re
from dataclasses import replace

import numpy as np
import pytest
import rosbag
import rospy
from geometry_msgs.msg import Point, Quaternion
from std_msgs.msg import Header

from hri_sync.dance_off.motion import load_motion
from hri_sync.fusion import ros_fuse_bag
from hri_sync.fusion.arms import turned
from hri_sync.fusion.frames import SensorPose, parse_pose
from hri_sync.fusion.relabel import exchanged_sides
from hri_sync.msg import ClockState, Skeleton
from hri_sync_support.fused_bags import POSES, fuse_bag

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))))
ORIGINAL = SensorPose(2.5, 0.0, 1.0, math.pi)   # the motion's own sensor
START = 1.8e9          # global time of the first capture
OFFSET = 0.3           # global minus the recorder's clock
STALL = 6.0            # s: the back view's last skeleton
DUR = 10.0


def truth(motion, stamp):
    return ORIGINAL.to_world(motion.positions_at([stamp - START])[0])


def write_recording(path, split=None):
    """The recording (recorder's clock = global - OFFSET); with ``split``
    (a recorder's time) in two parts, PATH_0.bag and PATH_1.bag, as
    ``rosbag record --split`` writes them."""
    motion = load_motion(os.path.join(ROOT, 'data', 'motion',
                                      'cmu_60_01_salsa.track'))
    rng = np.random.default_rng(7)
    poses = {v: parse_pose(p) for v, p in POSES.items()}
    records = []
    host = ClockState(client_id='recorder', ok=True, local_ref=START - OFFSET,
                      offset=OFFSET, uncertainty=0.0002, samples=5)
    records.append((START - OFFSET - 1.0, '/recorder/clock_state', host))
    for v in POSES:
        records.append((START - OFFSET - 0.5, '/%s/clock_state' % v,
                        ClockState(client_id=v, ok=True, local_ref=START,
                                   uncertainty=0.0005, samples=5)))
    for k in range(int(DUR * 30)):
        for i, (v, pose) in enumerate(poses.items()):
            stamp = START + k / 30 + 0.007 * i
            if v == 'back' and stamp - START > STALL:
                continue
            pts = pose.from_world(truth(motion, stamp)) \
                + rng.normal(0, 0.01, (15, 3))
            t = rospy.Time.from_sec(stamp)
            records.append((stamp + rng.uniform(0.05, 0.08) - OFFSET,
                            '/%s/skeleton' % v, Skeleton(
                                header=Header(stamp=t,
                                              frame_id='%s_sensor' % v),
                                client_id=v, user_id=1, device_stamp=t,
                                positions=[Point(*p) for p in pts],
                                orientations=[Quaternion(w=1.0)] * 15,
                                confidence=[0.9] * 15)))
    records.sort(key=lambda r: r[0])
    parts = [(path, records)] if split is None else [
        (path[:-4] + '_%d.bag' % i, [r for r in records
                                     if (r[0] >= split) == bool(i)])
        for i in (0, 1)]
    for part, chosen in parts:
        with rosbag.Bag(part, 'w') as bag:
            for t, topic, msg in chosen:
                bag.write(topic, msg, rospy.Time.from_sec(t))
    return motion


@pytest.fixture(scope='module')
def fused(tmp_path_factory):
    folder = tmp_path_factory.mktemp('fuse_bag')
    recording, out = str(folder / 'views.bag'), str(folder / 'fused.bag')
    motion = write_recording(recording)
    plain = folder / 'plain.yaml'     # a tracker with no known errors
    plain.write_text('{}\n')
    run = fuse_bag(recording, '--out', out, '--poses', str(POSES),
                   '--clock-state', '/recorder/clock_state',
                   '--profile', str(plain), '--set', 'smooth_accel=30')
    print(run.stdout, run.stderr)
    assert run.returncode == 0, run.stderr
    with rosbag.Bag(out) as bag:
        msgs = [(topic, msg, t.to_sec())
                for topic, msg, t in bag.read_messages()]
    return motion, msgs, run.stdout, folder


def test_the_person_is_fused_on_the_global_grid_near_the_motion(fused):
    motion, msgs, _, _ = fused
    skeletons = [(m, t) for topic, m, t in msgs
                 if topic == '/fused/skeleton']
    stamps = np.array([m.header.stamp.to_sec() for m, _ in skeletons])
    assert len(skeletons) >= 0.9 * DUR * 30
    assert {m.user_id for m, _ in skeletons} == {1}
    k = (stamps - START) * 30
    assert np.allclose(k, np.round(k), atol=1e-3)     # the 30 Hz grid
    output = parse_pose(POSES['left'])
    err = [np.linalg.norm(output.to_world(np.array(
        [(p.x, p.y, p.z) for p in m.positions]))
        - truth(motion, m.header.stamp.to_sec()), axis=1).mean()
        for m, _ in skeletons]
    assert np.median(err) < 0.03, np.median(err)
    # written (the recorder's clock) after the newest capture it used,
    # and its device_stamp the instant on that clock
    for m, t in skeletons:
        assert t + OFFSET > m.header.stamp.to_sec() + 0.05 - 1e-6
        assert m.device_stamp.to_sec() == pytest.approx(
            m.header.stamp.to_sec() - OFFSET, abs=1e-6)


def test_the_sources_follow_the_stall(fused):
    _, msgs, _, _ = fused
    skeletons = [m for topic, m, _ in msgs if topic == '/fused/skeleton']
    early = [set(m.sources) for m in skeletons
             if 1.0 < m.header.stamp.to_sec() - START < STALL - 0.5]
    late = [set(m.sources) for m in skeletons
            if m.header.stamp.to_sec() - START > STALL + 1.0]
    assert early and all(s == {'left', 'right', 'back'} for s in early)
    assert late and all(s == {'left', 'right'} for s in late)


def rotate(q, v):
    """Vector ``v`` turned by unit quaternion ``q`` (x, y, z, w)."""
    u, w = np.array(q[:3]), q[3]
    return v + 2 * np.cross(u, np.cross(u, v) + w * v)


def test_the_rep155_bodies_place_the_hips_in_world(fused):
    # /tf_static puts fused_sensor at the output pose in world; each fused
    # skeleton's body_fused1 (rep155_bridge's tree) then lies at the
    # dancer's hips centre; /humans/bodies/tracked names it 10 times a
    # second while fused, and nobody once it has been gone 0.5 s.
    motion, msgs, _, _ = fused
    static = [m.transforms for topic, m, _ in msgs if topic == '/tf_static']
    assert len(static) == 1 and len(static[0]) == 1
    sensor = static[0][0]
    assert (sensor.header.frame_id, sensor.child_frame_id) == (
        'world', 'fused_sensor')
    r, t = sensor.transform.rotation, sensor.transform.translation
    q, origin = (r.x, r.y, r.z, r.w), np.array([t.x, t.y, t.z])
    assert np.allclose(origin, [3.3, 0.4, 1.0])
    bodies = [(m.transforms[0], time) for topic, m, time in msgs
              if topic == '/tf']
    skeletons = [m for topic, m, _ in msgs if topic == '/fused/skeleton']
    assert len(bodies) == len(skeletons)
    err = []
    for body, _ in bodies:
        assert (body.header.frame_id, body.child_frame_id) == (
            'fused_sensor', 'body_fused1')
        p = body.transform.translation
        hips = truth(motion, body.header.stamp.to_sec())[[9, 10]].mean(0)
        err.append(np.linalg.norm(
            rotate(q, np.array([p.x, p.y, p.z])) + origin - hips))
    assert np.median(err) < 0.05, np.median(err)
    tracked = [(m.ids, time) for topic, m, time in msgs
               if topic == '/humans/bodies/tracked']
    first, last = bodies[0][1], bodies[-1][1]
    during = [ids for ids, time in tracked if time <= last]
    assert abs(len(during) - 10 * (last - first)) <= 2
    assert all(ids == ['fused1'] for ids in during)
    assert all(ids == [] for ids, time in tracked if time > last + 0.6)


def test_diagnostics_name_the_stalled_view(fused):
    _, msgs, stdout, _ = fused
    diags = [(m, t) for topic, m, t in msgs if topic == '/diagnostics']
    assert len(diags) >= DUR - 1
    # the last before the recording ends (after it every view stalls)
    late = [m for m, t in diags if STALL + 1 < t + OFFSET - START < DUR]
    last = {s.name: s for s in late[-1].status}
    assert last['fused/fusion: view back'].level == 2
    assert 'stalled' in last['fused/fusion: view back'].message
    assert last['fused/fusion: view left'].level == 0
    assert 'ERROR view back: stalled' in stdout
    assert 'OK    calibration: views agree' in stdout
    pairs = re.search(r'back-left (\d+) mm, back-right (\d+) mm, '
                      r'left-right (\d+) mm', stdout)
    assert pairs and all(int(mm) < 100 for mm in pairs.groups()), stdout
    assert 'instants fused' in stdout


def test_a_split_recording_is_fused_as_one(fused):
    _, msgs, _, folder = fused
    recording = str(folder / 'split.bag')
    write_recording(recording, split=START - OFFSET + DUR / 2)
    out = str(folder / 'split_fused.bag')
    run = fuse_bag(recording[:-4] + '_0.bag', recording[:-4] + '_1.bag',
                   '--out', out, '--poses', str(POSES), '--clock-state',
                   '/recorder/clock_state', '--profile',
                   str(folder / 'plain.yaml'), '--set', 'smooth_accel=30')
    assert run.returncode == 0, run.stderr
    with rosbag.Bag(out) as bag:
        again = [(topic, t.to_sec()) for topic, _, t in bag.read_messages()]
    assert again == [(topic, t) for topic, _, t in msgs]


def exchanged_skeletons(pairs):
    """How many of the (before, after) Skeleton ``pairs`` differ; each that
    does is the one before with its left and right exchanged."""
    changed = 0
    for a, b in pairs:
        pa, pb = [np.array([(p.x, p.y, p.z) for p in m.positions])
                  for m in (a, b)]
        if not np.array_equal(pa, pb):
            np.testing.assert_array_equal(pb, turned(pa))
            changed += 1
    return changed


def test_labels_from_later_fuse_the_same_instants(fused):
    _, msgs, _, folder = fused
    out = str(folder / 'relabelled.bag')
    run = fuse_bag(str(folder / 'views.bag'), '--out', out, '--poses',
                   str(POSES), '--clock-state', '/recorder/clock_state',
                   '--profile', str(folder / 'plain.yaml'), '--set',
                   'smooth_accel=30', '--labels-from-later')
    assert run.returncode == 0, run.stderr
    exchanged = re.search(r'(\d+) person-instants given their left and '
                          r'right from later sure instants \(exchanged\)',
                          run.stdout)
    assert exchanged, run.stdout
    with rosbag.Bag(out) as bag:
        again = [(topic, msg, t.to_sec())
                 for topic, msg, t in bag.read_messages()]
    assert [(topic, t) for topic, _, t in again] == \
        [(topic, t) for topic, _, t in msgs]
    skeletons = [(a, b) for (topic, a, _), (_, b, _) in zip(msgs, again)
                 if topic.endswith('/skeleton')]
    assert exchanged_skeletons(skeletons) == int(exchanged.group(1))


def test_the_relabelled_instants_are_the_ones_written(fused, monkeypatch):
    # fuse_bag in this process, every tenth fused instant's people given
    # exchanged sides by the look-ahead: those, and only those, are
    # written exchanged.
    _, msgs, _, folder = fused
    exchanged_at = set()

    def every_tenth(frames):
        out = []
        for k, frame in enumerate(frames):
            if k % 10 == 0 and frame.people:
                exchanged_at.add(frame.stamp)
                frame = replace(frame, people=[exchanged_sides(p)
                                               for p in frame.people])
            out.append(frame)
        return out, len(exchanged_at)

    monkeypatch.setattr(ros_fuse_bag, 'labels_from_later', every_tenth)
    out = str(folder / 'every_tenth.bag')
    assert ros_fuse_bag.main([
        str(folder / 'views.bag'), '--out', out, '--poses', str(POSES),
        '--clock-state', '/recorder/clock_state', '--profile',
        str(folder / 'plain.yaml'), '--set', 'smooth_accel=30',
        '--labels-from-later']) == 0
    with rosbag.Bag(out) as bag:
        again = [msg for _, msg, _ in bag.read_messages('/fused/skeleton')]
    before = [msg for topic, msg, _ in msgs if topic == '/fused/skeleton']
    assert len(again) == len(before) and exchanged_at
    assert exchanged_skeletons(zip(before, again)) == len(exchanged_at)


def test_bad_options_and_a_recording_without_the_views(fused):
    _, _, _, folder = fused
    recording = str(folder / 'views.bag')
    out = str(folder / 'other.bag')
    run = fuse_bag(recording, '--out', out, '--poses', str(POSES), '--set',
                   'max_age=-1')
    assert run.returncode == 2 and 'max_age=-1.0 is out of range' \
        in run.stderr
    run = fuse_bag(recording, '--out', out, '--poses', str(POSES),
                   '--set', 'x=1')
    assert run.returncode == 2 and 'NAME one of rate' in run.stderr
    run = fuse_bag(recording, '--out', out, '--poses',
                   "{a: '0 0 1 0', b: '1 0 1 0'}")
    assert run.returncode == 1, run.stdout
    assert '0 with people' in run.stdout
    assert 'view a: no /a/skeleton in the recording (its hri_sync/Skeleton ' \
        'topics: /back/skeleton, /left/skeleton, /right/skeleton)' \
        in run.stderr
    run = fuse_bag(str(folder / 'none.bag'), '--out', out, '--poses',
                   str(POSES))
    assert run.returncode == 2 and 'none.bag' in run.stderr
    run = fuse_bag(recording, '--out', out, '--poses', str(POSES),
                   '--skeleton-topic', '/skeleton')
    assert run.returncode == 2 and 'a topic with one %s' in run.stderr
    run = fuse_bag(recording, '--out', recording, '--poses', str(POSES))
    assert run.returncode == 2 and 'is one of the recording' in run.stderr
