"""fuse_bag: a recording of three views fused afterwards.

Writes a bag as ``rosbag record`` would have on a host whose clock is
0.3 s behind the global clock (its ClockState says so): three views of
data/motion/cmu_60_01_salsa.track at 30 Hz from their poses, 1 cm noise,
each skeleton recorded 50-80 ms after its capture, the back view stalled
from 6 s on.  Runs ``fuse_bag`` on it (no roscore) and checks what it
wrote: a fused person on the 30 Hz grid of the global clock, near the
motion, from all three views until the stall and two after, recorded
after the newest capture it used; the back view's diagnostics ERROR
``stalled`` at the end; and that a bad setting, views the bag lacks and
a missing bag each give a clear error and exit status.  Run by
scripts/run_rostests.py (make test) with the workspace sourced.
"""
import math
import os
import subprocess

import numpy as np
import pytest
import rosbag
import rospy
from geometry_msgs.msg import Point, Quaternion
from std_msgs.msg import Header

from hri_sync.dance_off.motion import load_motion
from hri_sync.fusion.frames import SensorPose, parse_pose
from hri_sync.msg import ClockState, Skeleton

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))))
POSES = {'left': '3.3 0.4 1.0 -3.02', 'right': '0.5 -3.3 1.0 1.72',
         'back': '-2.3 2.3 1.0 -0.785'}
ORIGINAL = SensorPose(2.5, 0.0, 1.0, math.pi)   # the motion's own sensor
START = 1.8e9          # global time of the first capture
OFFSET = 0.3           # global minus the recorder's clock
STALL = 6.0            # s: the back view's last skeleton
DUR = 10.0


def truth(motion, stamp):
    return ORIGINAL.to_world(motion.positions_at([stamp - START])[0])


def write_recording(path):
    """The recording (recorder's clock = global - OFFSET)."""
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
    with rosbag.Bag(path, 'w') as bag:
        for t, topic, msg in sorted(records, key=lambda r: r[0]):
            bag.write(topic, msg, rospy.Time.from_sec(t))
    return motion


def fuse_bag(*args):
    return subprocess.run(['rosrun', 'hri_sync', 'fuse_bag'] + list(args),
                          capture_output=True, text=True, timeout=300)


@pytest.fixture(scope='module')
def fused(tmp_path_factory):
    folder = tmp_path_factory.mktemp('fuse_bag')
    recording, out = str(folder / 'views.bag'), str(folder / 'fused.bag')
    motion = write_recording(recording)
    plain = folder / 'plain.yaml'     # a tracker with no known errors
    plain.write_text('{}\n')
    run = fuse_bag(recording, out, '--poses', str(POSES),
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
    assert 'instants fused' in stdout


def test_bad_options_and_a_recording_without_the_views(fused):
    _, _, _, folder = fused
    recording = str(folder / 'views.bag')
    out = str(folder / 'other.bag')
    run = fuse_bag(recording, out, '--poses', str(POSES), '--set',
                   'max_age=-1')
    assert run.returncode == 2 and 'max_age=-1.0 is out of range' \
        in run.stderr
    run = fuse_bag(recording, out, '--poses', str(POSES), '--set', 'x=1')
    assert run.returncode == 2 and 'NAME one of rate' in run.stderr
    run = fuse_bag(recording, out, '--poses', "{a: '0 0 1 0', b: '1 0 1 0'}")
    assert run.returncode == 1, run.stdout
    assert '0 with people' in run.stdout
    run = fuse_bag(str(folder / 'none.bag'), out, '--poses', str(POSES))
    assert run.returncode == 2 and 'none.bag' in run.stderr
