"""hri_sync.fusion.relabel: a recording's people whose sides were in doubt
take their labels from the next instant whose sides were sure, by the
front's continuity; the chain ends at a gap, at a turn it cannot tell
from an exchange, or at a sure instant the next confirms (a lone one is
carried); the frames given are not changed."""
import math

import numpy as np

from hri_sync.dance_off.frames import rotation
from hri_sync.dance_off.joints import INDEX, NUM_JOINTS
from hri_sync.fusion.arms import turned
from hri_sync.fusion.facing import front
from hri_sync.fusion.fuse import Fused
from hri_sync.fusion.pipeline import Frame, Person
from hri_sync.fusion.relabel import exchanged_sides, labels_from_later
from test_fusion_core import body

STEP = 1.0 / 30


def facing(degrees, x=0.0):
    """The standing body at (x, 0) turned ``degrees`` about the vertical
    from facing +x."""
    p = body()
    return (p - p[INDEX['torso']]) @ rotation(math.radians(degrees)).T \
        + (x, 0.0, p[INDEX['torso'], 2])


def person(positions, doubt, pid=1):
    """A fused person at ``positions``: left joints at confidence 0.9,
    right at 0.4, bounds 0.1 m on the left and 0.3 m on the right."""
    left = np.array(['left' in name for name in sorted(
        INDEX, key=INDEX.get)])
    return Person(pid, Fused(positions, np.where(left, 0.9, 0.4),
                             np.where(left, 0.1, 0.3), ['a', 'b'],
                             sigma=np.where(left, 0.02, 0.05)),
                  0.0, doubt)


def frames_of(bodies, doubts, start=100.0, step=STEP):
    """One person's frames, an instant ``step`` s apart."""
    return [Frame(start + k * step, [person(p, d)], 0.0)
            for k, (p, d) in enumerate(zip(bodies, doubts))]


def fronts(frames):
    """The one person's front at each of ``frames``."""
    return [front(f.people[0].body.positions) for f in frames]


def facing_x():
    return np.array([1.0, 0.0, 0.0])


def test_a_start_in_doubt_takes_the_labels_of_the_first_sure_instant():
    bodies = [turned(facing(0))] * 10 + [facing(0)] * 5
    frames = frames_of(bodies, [True] * 10 + [False] * 5)
    out, exchanged = labels_from_later(frames)
    assert exchanged == 10
    for k, (f, given) in enumerate(zip(out, frames)):
        np.testing.assert_allclose(f.people[0].body.positions, facing(0))
        moved = turned if k < 10 else (lambda a: a)
        for name in ('confidence', 'bound', 'sigma'):
            np.testing.assert_array_equal(
                getattr(f.people[0].body, name),
                moved(getattr(given.people[0].body, name)))
    assert [f.people[0].sides_in_doubt for f in out] == [True] * 10 \
        + [False] * 5
    # the frames given are as they were
    np.testing.assert_allclose(frames[0].people[0].body.positions,
                               turned(facing(0)))


def test_labels_in_doubt_that_continue_are_kept():
    frames = frames_of([facing(3 * k) for k in range(20)],
                       [True] * 15 + [False] * 5)
    out, exchanged = labels_from_later(frames)
    assert exchanged == 0
    for a, b in zip(out, frames):
        np.testing.assert_array_equal(a.people[0].body.positions,
                                      b.people[0].body.positions)


def test_an_exchange_inside_a_turning_run_is_undone_before_it():
    true = [facing(4 * k) for k in range(30)]
    bodies = [turned(p) if k < 12 else p for k, p in enumerate(true)]
    out, exchanged = labels_from_later(
        frames_of(bodies, [True] * 25 + [False] * 5))
    assert exchanged == 12
    for f, p in zip(out, true):
        np.testing.assert_allclose(f.people[0].body.positions, p)


def test_a_gap_ends_the_chain():
    bodies = [turned(facing(0))] * 10 + [facing(0)] * 5
    frames = frames_of(bodies, [True] * 10 + [False] * 5)
    late = [Frame(f.stamp + 0.3, f.people, f.published) for f in frames[5:]]
    out, exchanged = labels_from_later(frames[:5] + late)
    assert exchanged == 5
    assert all(fr @ facing_x() < 0 for fr in fronts(out[:5]))
    assert all(fr @ facing_x() > 0 for fr in fronts(out[5:]))


def test_doubt_after_the_last_sure_instant_is_kept():
    bodies = [facing(0)] * 5 + [turned(facing(0))] * 5
    out, exchanged = labels_from_later(
        frames_of(bodies, [False] * 5 + [True] * 5))
    assert exchanged == 0
    assert all(fr @ facing_x() < 0 for fr in fronts(out[5:]))


def test_an_instant_without_a_front_is_bridged_and_kept():
    hips_together = facing(0)
    for hip in ('left_hip', 'right_hip'):
        hips_together[INDEX[hip], 1] = 0.0
    bodies = [turned(facing(0))] * 5 + [hips_together] * 3 \
        + [facing(0)] * 3
    out, exchanged = labels_from_later(
        frames_of(bodies, [True] * 8 + [False] * 3))
    assert exchanged == 5
    assert all(fr @ facing_x() > 0 for fr in fronts(out[:5]))
    for f in out[5:8]:
        np.testing.assert_array_equal(f.people[0].body.positions,
                                      hips_together)


def test_a_turn_it_cannot_tell_from_an_exchange_ends_the_chain():
    # 90 degrees between two instants: an exchange or a quick turn
    bodies = [turned(facing(90))] * 5 + [facing(0)] * 3
    out, exchanged = labels_from_later(
        frames_of(bodies, [True] * 5 + [False] * 3))
    assert exchanged == 0
    # An exchange the filter spread over instants: the labels right, then
    # swung round by about 60 degrees a step to the wrong way, then sure
    # and right: the last wrong one is put right, the chain ends at the
    # swing and the instants before it keep their (right) labels.
    bodies = [facing(0)] * 5 + [facing(62), facing(125), turned(facing(0))] \
        + [facing(0)] * 3
    out, exchanged = labels_from_later(
        frames_of(bodies, [True] * 8 + [False] * 3))
    assert exchanged == 1
    np.testing.assert_allclose(out[7].people[0].body.positions, facing(0))
    for f, p in zip(out[:5], bodies[:5]):
        np.testing.assert_array_equal(f.people[0].body.positions, p)


def test_each_person_takes_its_own_later_labels():
    frames = []
    for k in range(10):
        sure = k >= 6
        a = person(facing(0) if sure else turned(facing(0)), not sure, 1)
        b = person(facing(180, x=3.0), True, 2)
        frames.append(Frame(100.0 + k * STEP, [b, a] if k % 2 else [a, b],
                            0.0))
    out, exchanged = labels_from_later(frames)
    assert exchanged == 6
    for f in out:
        by_id = {p.person: p for p in f.people}
        np.testing.assert_allclose(by_id[1].body.positions, facing(0))
        np.testing.assert_allclose(by_id[2].body.positions,
                                   facing(180, x=3.0))


def test_exchanged_sides_moves_every_per_joint_figure():
    p = person(facing(0), True)
    q = exchanged_sides(p)
    left, right = INDEX['left_elbow'], INDEX['right_elbow']
    for name in ('positions', 'confidence', 'bound', 'sigma', 'scatter'):
        np.testing.assert_array_equal(getattr(q.body, name)[left],
                                      getattr(p.body, name)[right])
    assert q.body.views == p.body.views and q.sides_in_doubt
    assert len(q.body.positions) == NUM_JOINTS


def test_a_sure_instant_without_a_front_is_passed_over():
    hips_together = facing(0)
    for hip in ('left_hip', 'right_hip'):
        hips_together[INDEX[hip], 1] = 0.0
    bodies = [turned(facing(0))] * 5 + [hips_together] + [facing(0)] * 3
    out, exchanged = labels_from_later(
        frames_of(bodies, [True] * 5 + [False] * 4))
    assert exchanged == 5
    assert all(fr @ facing_x() > 0 for fr in fronts(out[:5]))


def test_a_lone_sure_instant_takes_the_labels_a_confirmed_later_run_gives():
    # One instant the hands decided wrongly (sure, alone), the instants in
    # doubt around it: the sure run after them puts them and it right, and
    # the chain goes on through the right ones before it unchanged.
    wrong = turned(facing(0))
    bodies = [facing(0)] * 5 + [wrong] * 4 + [facing(0)] * 3
    doubts = [True] * 5 + [False] + [True] * 3 + [False] * 3
    out, exchanged = labels_from_later(frames_of(bodies, doubts))
    assert exchanged == 4
    for f in out:
        np.testing.assert_allclose(f.people[0].body.positions, facing(0))


def test_a_lone_sure_instant_no_chain_reaches_decides_before_it():
    frames = frames_of([turned(facing(0))] * 5 + [facing(0)],
                       [True] * 5 + [False])
    later = [Frame(frames[-1].stamp + 0.3 + k * STEP,
                   [person(turned(facing(0)), False)], 0.0)
             for k in range(3)]
    out, exchanged = labels_from_later(frames + later)
    assert exchanged == 5
    assert all(fr @ facing_x() > 0 for fr in fronts(out[:6]))
    assert all(fr @ facing_x() < 0 for fr in fronts(out[6:]))
