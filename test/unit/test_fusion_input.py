"""hri_sync.fusion: what the views send as it arrives. A lost frame is
not waited for past the time it was due; a skeleton repeated joint for
joint (a Kinect SDK repeats its last one) is no new measurement: left
out, counted, and a view that only repeats is named frozen."""
import numpy as np

from hri_sync.fusion.pipeline import Fusion
from hri_sync.fusion.report import ERROR, WARN, view_status
from test_fusion_wrong_pose import ORIGINAL, POSES, dancer

LATENCY = 0.05      # s from capture to the fusion


def feed(frames_of, seconds=3.0, rate=30.0, poll=0.005):
    """A Fusion of POSES' views of the dancer, each skeleton arriving
    LATENCY after its capture, polled every ``poll`` s; ``frames_of(view,
    k)``: the frame whose joints view sends as its k-th (None: lost).
    Returns the fusion, its frames and the truth."""
    motion, rng = dancer(), np.random.default_rng(7)
    clock = {'now': 0.0}
    fusion = Fusion(POSES, None, lambda: clock['now'])
    noise = {v: rng.normal(0, 0.01, (int(seconds * rate), 15, 3))
             for v in POSES}
    arrivals = sorted((k / rate + LATENCY, view, k) for view in POSES
                      for k in range(int(seconds * rate)))
    frames, tick = [], 0.0
    for when, view, k in arrivals:
        while tick < when:
            clock['now'] = tick
            frames += fusion.poll()
            tick += poll
        n = frames_of(view, k)
        if n is None:
            continue
        world = ORIGINAL.to_world(motion.positions_at([n / rate])[0])
        clock['now'] = when
        fusion.add(view, 1, k / rate, POSES[view].from_world(world)
                   + noise[view][n], np.full(15, 0.9), 0.001)
        frames += fusion.poll()

    def truth(t):
        return ORIGINAL.to_world(motion.positions_at([t])[0])
    return fusion, frames, truth


def test_a_lost_frame_is_not_waited_for_past_its_due_time():
    # The view behind loses its frame 40: the instant that needed it is
    # out once that frame is due (capture + latency + 5 ms), not a frame
    # period later; every other instant is out when its last view's
    # skeleton arrives.
    def lost(view, k):
        return None if view == 'back' and k == 40 else k

    fusion, frames, _ = feed(lost, seconds=2.0)
    late = {round(f.stamp * 30): f.published - f.stamp for f in frames}
    assert 0.005 - 1e-9 <= late[40] - LATENCY <= 0.0101
    assert max(v for k, v in late.items() if k not in (39, 40)) \
        <= LATENCY + 0.0051


def test_a_repeated_skeleton_is_left_out_and_counted():
    # The view on the right repeats its skeleton once a second (its
    # frames 30, 60 sent again as 31, 61): both are left out and counted;
    # the view is fused, WARN `repeated`.
    def once(view, k):
        return k - 1 if view == 'right' and k % 30 == 1 and k > 1 else k

    fusion, frames, _ = feed(once)
    name, level, message, values = view_status(fusion, 'right')
    assert level == WARN and message.startswith('repeated: 2 skeletons')
    assert dict(values)['rejected repeated_skeleton'] == '2'
    assert not fusion.faults()['left'] and not fusion.faults()['back']
    assert all(len(f.people) == 1 for f in frames if f.stamp > 1.0)


def test_a_view_that_only_repeats_is_frozen_and_left_out():
    # From 1 s the view on the right sends its skeleton of 1 s again and
    # again, with fresh stamps: after 0.5 s it is `frozen` (ERROR), and
    # the dancer is fused from the other two, where they are, not
    # dragged towards the still pose.
    def frozen(view, k):
        return min(k, 30) if view == 'right' else k

    fusion, frames, truth = feed(frozen)
    name, level, message, _ = view_status(fusion, 'right')
    assert level == ERROR and message.startswith('frozen')
    assert fusion.faults() == {'left': [], 'back': [],
                               'right': fusion.faults()['right']}
    late = [f for f in frames if f.stamp >= 1.6]
    assert late and all(len(f.people) == 1 for f in late)
    assert all(sorted(f.people[0].body.views) == ['back', 'left']
               for f in late)
    error = [np.linalg.norm(f.people[0].body.positions - truth(f.stamp),
                            axis=1).mean() for f in late]
    assert max(error) < 0.03
