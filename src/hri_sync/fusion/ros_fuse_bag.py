"""``fuse_bag BAG... --out OUT.bag --poses YAML``: a recording's views
fused afterwards (the executable is ``nodes/fuse_bag``; docs/fusion.md).

Reads each view's hri_sync/Skeleton (/<view>/skeleton), ClockState
(/<view>/clock_state) and, if recorded, its tracker's status
(/<view>/tracker/sensor_status) from a recording (several bags, as the
parts of a ``rosbag record --split``, are read as one, in time order),
runs the fusion node's core on them in the order the recorder got them,
its clock the recorder's (through the recorder host's ClockState,
--clock-state, when recorded), and writes what the node would have
published to OUT.bag at the time it would have: /<client-id>/skeleton
(a hri_sync/Skeleton per person, a DPM input like the live one),
/<client-id>/joints (each joint's 95 % bound), the fusion's /diagnostics
each second, and the REP 155 bodies fusion.launch's rep155_bridge gives
(/tf: body_<client-id><person> under <client-id>_sensor, whose pose in
the world frame is on /tf_static; /humans/bodies/tracked every 0.1 s).
A study recorded raw can be fused again with refined poses
(scripts/fusion_refine_pose.py) or other settings (--set NAME=VALUE, the
launch file's args), and with --labels-from-later each person's instants
whose left and right were in doubt take the labels of the next sure one
(hri_sync.fusion.relabel: every fused instant is held in memory until
the recording has been fused, then written). Prints the views' and people's
statuses at the end.

Needs no roscore. Exit status: 0 fused; 1 nothing fused; 2 bad options or
a bag it cannot read.
"""
import argparse
import contextlib
import heapq
import os
import sys
from typing import List, NamedTuple, Optional, Tuple

import rosbag
import rospkg
import rospy
import yaml
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from tf2_msgs.msg import TFMessage

from hri_sync.dance_off.frames import SENSOR, pose
from hri_sync.fusion.feed import (
    HOST_CLOCK, SKELETON, VIEW_CLOCK, VIEW_STATUS, VIEW_TOPICS, Recorded,
    Replay, to_global)
from hri_sync.fusion.frames import parse_pose
from hri_sync.fusion.pipeline import Frame, Fusion
from hri_sync.fusion.profile import profiles
from hri_sync.fusion.relabel import labels_from_later
from hri_sync.fusion.report import statuses
from hri_sync.fusion.ros_fusion import fused_messages
from hri_sync.fusion.settings import NAMES, fusion_params
from hri_sync.msg import Skeleton
from hri_sync.people.rep155 import BODY_ID, TrackedBodies
from hri_sync.people.ros_rep155 import body_tf, ids_list
from hri_sync.ros.transforms import transform

LEVELS = {0: 'OK', 1: 'WARN', 2: 'ERROR'}
# s: /humans/bodies/tracked's period and how long a body stays in it
# (rep155_bridge's defaults)
TRACKED_PERIOD, FORGET_AFTER = 0.1, 0.5


class Taken(NamedTuple):
    """A fusion step, all the bag is given of it: its time, its frames
    with their stamps on the recorder's clock, its /diagnostics (or
    None)."""

    t: float
    frames: List[Tuple[Frame, float]]
    status: Optional[DiagnosticArray]


def arguments(argv):
    parser = argparse.ArgumentParser(prog='fuse_bag',
                                     description=__doc__.split('\n')[0])
    parser.add_argument('bags', nargs='+', metavar='BAG',
                        help='the recording (its parts, if split)')
    parser.add_argument('--out', required=True, metavar='OUT.bag',
                        help='the bag written')
    parser.add_argument('--poses', required=True, help="YAML {view: 'x y z "
                        "yaw [pitch]'}: each view's sensor pose in world")
    parser.add_argument('--output-pose', help='x y z yaw [pitch] of the '
                        "fused Skeleton's virtual sensor (default: the "
                        "first view's)")
    parser.add_argument('--profile', help="the trackers' profile (YAML; "
                        "default: the package's config/"
                        "fusion_depth_tracker.yaml, as fusion.launch)")
    parser.add_argument('--client-id', default='fused')
    parser.add_argument('--world-frame', default='world')
    parser.add_argument('--skeleton-topic', default=VIEW_TOPICS[SKELETON])
    parser.add_argument('--clock-topic', default=VIEW_TOPICS[VIEW_CLOCK])
    parser.add_argument('--status-topic', default=VIEW_TOPICS[VIEW_STATUS])
    parser.add_argument('--clock-state', default='', help="the recorder "
                        "host's ClockState topic ('': its clock is the "
                        'global clock)')
    parser.add_argument('--stamp-uncertainty', type=float, default=0.001)
    parser.add_argument('--labels-from-later', action='store_true',
                        help="give each person's instants whose left and "
                        'right were in doubt the labels of the next sure '
                        'one (every fused instant held in memory until '
                        'the end; hri_sync.fusion.relabel)')
    parser.add_argument('--set', action='append', default=[],
                        metavar='NAME=VALUE', help='a fusion setting: '
                        + ', '.join(NAMES))
    return parser, parser.parse_args(argv)


def default_profile():
    return os.path.join(rospkg.RosPack().get_path('hri_sync'), 'config',
                        'fusion_depth_tracker.yaml')


def settings(parser, pairs):
    values = {}
    for pair in pairs:
        name, sep, value = pair.partition('=')
        if not sep or name not in NAMES:
            parser.error('--set %s: NAME=VALUE, NAME one of %s'
                         % (pair, ', '.join(NAMES)))
        values[name] = value
    try:
        return fusion_params(lambda n, d: values.get(n, d))
    except ValueError as e:
        parser.error('--set: %s' % e)


def open_bag(path):
    """A recording opened to read; a ValueError naming it if it cannot
    be."""
    try:
        return rosbag.Bag(path)
    except (rosbag.ROSBagException, OSError) as e:
        raise ValueError('%s: %s' % (path, e))


def say_missing(bags, topics):
    """Name each view topic the recording lacks, beside the Skeleton
    topics it holds (a view id or --skeleton-topic mistyped)."""
    held = {topic for bag in bags for topic, info
            in bag.get_type_and_topic_info().topics.items()
            if info.msg_type == Skeleton._type}
    for topic, (kind, view) in sorted(topics.items()):
        if kind == SKELETON and topic not in held:
            print('fuse_bag: view %s: no %s in the recording (its %s '
                  'topics: %s)' % (view, topic, Skeleton._type,
                                   ', '.join(sorted(held)) or 'none'),
                  file=sys.stderr)


def records(bag, topics):
    """The bag's messages of ``topics`` ({topic: (kind, view)}) as
    Recorded, in the order recorded."""
    for topic, msg, t in bag.read_messages(topics=list(topics)):
        kind, view = topics[topic]
        yield Recorded(t.to_sec(), kind, view, msg)


def diagnostics(fusion, last, t, name, hardware_id):
    arr = DiagnosticArray()
    arr.header.stamp = rospy.Time.from_sec(t)
    for task, level, message, values in statuses(fusion, last):
        arr.status.append(DiagnosticStatus(
            level=level, name='%s: %s' % (name, task), message=message,
            hardware_id=hardware_id,
            values=[KeyValue(k, v) for k, v in values]))
    return arr


class Output:
    """The bag written: each step's fused frames and diagnostics, and a
    tally of what went in."""

    def __init__(self, bag, replay, output_pose, args):
        self.bag, self.replay = bag, replay
        self.output_pose, self.args = output_pose, args
        self.fused = self.people = 0
        self.ids, self.last, self.summary = set(), None, []
        self.bodies, self.tracked_at = TrackedBodies(FORGET_AFTER), None
        self.exchanged = None   # person-instants relabelled, if asked

    def rep155(self, t, skeletons):
        """The bodies' tf; the sensor frame's pose first."""
        if self.tracked_at is None:
            p = self.output_pose
            self.bag.write('/tf_static', TFMessage([transform(
                t, self.args.world_frame, self.args.client_id + '_sensor',
                *pose(p.x, p.y, p.z, p.yaw, p.pitch, SENSOR))]), t)
            self.tracked_at = t.to_sec()
        for msg in skeletons:
            body = BODY_ID.format(client_id=msg.client_id,
                                  user_id=msg.user_id)
            tf = body_tf(msg, body)
            if tf is not None:
                self.bag.write('/tf', tf, t)
                self.bodies.saw(body, t.to_sec(), msg.header.stamp)

    def tracked(self, t):
        """/humans/bodies/tracked every TRACKED_PERIOD until ``t``."""
        while self.tracked_at is not None and t >= self.tracked_at:
            self.bag.write('/humans/bodies/tracked', ids_list(
                *self.bodies.tracked(self.tracked_at)),
                rospy.Time.from_sec(self.tracked_at))
            self.tracked_at += TRACKED_PERIOD

    def take(self, step):
        """What ``step`` writes, with all of it that the fusion's state
        then decides: its frames, each with its stamp on the recorder's
        clock, and its diagnostics if due."""
        frames = [(frame, to_global(frame.stamp, self.replay.host, True))
                  for frame in step.frames]
        self.last = step.frames[-1] if step.frames else self.last
        status = None
        if step.status_due:
            status = diagnostics(self.replay.fusion, self.last, step.t,
                                 self.args.client_id + '/fusion',
                                 self.args.client_id)
        if step.ended:      # the statuses as the recording ended
            self.summary = statuses(self.replay.fusion, self.last)
        return Taken(step.t, frames, status)

    def write(self, taken, relabelled=None):
        """Writes a step taken, each frame the look-ahead relabelled
        (``relabelled``, {stamp: frame}) in its stead."""
        t, cid = rospy.Time.from_sec(taken.t), self.args.client_id
        for frame, local in taken.frames:
            frame = (relabelled or {}).get(frame.stamp, frame)
            skeletons, cloud = fused_messages(
                frame, local, self.output_pose, cid, self.args.world_frame)
            for msg in skeletons:
                self.bag.write('/%s/skeleton' % cid, msg, t)
            self.bag.write('/%s/joints' % cid, cloud, t)
            self.rep155(t, skeletons)
            self.fused += 1
            self.people += bool(frame.people)
            self.ids.update(p.person for p in frame.people)
        self.tracked(taken.t)
        if taken.status is not None:
            self.bag.write('/diagnostics', taken.status, t)

    def report(self):
        print('fuse_bag: %d instants fused, %d with people (%s); written '
              'to %s' % (self.fused, self.people, ', '.join(
                  'person %d' % i for i in sorted(self.ids)) or 'nobody',
                  self.args.out))
        if self.exchanged is not None:
            print('%d person-instants given their left and right from '
                  'later sure instants (exchanged)' % self.exchanged)
        print('at the end of the recording:')
        for task, level, message, values in self.summary:
            print('  %-5s %s: %s' % (LEVELS[level], task, message))
            if task == 'calibration' and values:   # each pair's residual
                print('        %s' % ', '.join(
                    '%s %s mm' % (k[:-len(' (mm)')], v)
                    if k.endswith(' (mm)') else '%s %s' % (k, v)
                    for k, v in values))
        if self.replay.bad_host_states:
            print('  %s: %d ClockStates left out (no usable clock model)'
                  % (self.args.clock_state, self.replay.bad_host_states))
        for v, health in sorted(self.replay.fusion.health.items()):
            if health.rejected:
                print('  %s left out: %s' % (v, ', '.join(
                    '%d %s' % (n, r) for r, n in sorted(
                        health.rejected.items()))))


def setup(parser, args):
    """(poses, output pose, profiles, params, topics) from the options;
    a usage error on a bad one."""
    try:
        given = yaml.safe_load(args.poses)
        poses = {v: parse_pose(p) for v, p in given.items()}
        output_pose = parse_pose(args.output_pose
                                 or str(given[next(iter(given))]))
        with open(args.profile or default_profile()) as f:
            profile = profiles(yaml.safe_load(f) or {}, list(poses))
    except (AttributeError, OSError, StopIteration, ValueError,
            yaml.YAMLError, rospkg.ResourceNotFound) as e:
        parser.error('--poses, --output-pose or --profile: %s' % e)
    if len(poses) < 2:
        parser.error('--poses: at least two views')
    if os.path.abspath(args.out) in map(os.path.abspath, args.bags):
        parser.error('--out %s is one of the recording\'s bags' % args.out)
    if not args.stamp_uncertainty >= 0:
        parser.error('--stamp-uncertainty must be >= 0 s')
    for name in ('skeleton_topic', 'clock_topic', 'status_topic'):
        pattern = getattr(args, name)
        if pattern.count('%s') != 1 or pattern.count('%') != 1:
            parser.error('--%s %s: a topic with one %%s, the view id (as '
                         '/%%s/skeleton)' % (name.replace('_', '-'), pattern))
    topics = {}
    for v in poses:
        topics[args.skeleton_topic % v] = (SKELETON, v)
        topics[args.clock_topic % v] = (VIEW_CLOCK, v)
        topics[args.status_topic % v] = (VIEW_STATUS, v)
    if args.clock_state:
        topics[args.clock_state] = (HOST_CLOCK, '')
    return poses, output_pose, profile, settings(parser, args.set), topics


def main(argv=None):
    """Runs fuse_bag; its exit status."""
    parser, args = arguments(argv)
    poses, output_pose, profile, params, topics = setup(parser, args)

    try:
        with contextlib.ExitStack() as stack:
            bags = [stack.enter_context(open_bag(b)) for b in args.bags]
            say_missing(bags, topics)
            replay = Replay(lambda clock: Fusion(poses, params, clock,
                                                 profile),
                            extra=args.stamp_uncertainty)
            steps = replay.run(heapq.merge(
                *(records(b, topics) for b in bags), key=lambda r: r.t))
            output = Output(stack.enter_context(rosbag.Bag(args.out, 'w')),
                            replay, output_pose, args)
            if not args.labels_from_later:
                for step in steps:
                    output.write(output.take(step))
            else:       # every step taken, then written relabelled
                taken = [output.take(step) for step in steps]
                frames, output.exchanged = labels_from_later(
                    [frame for step in taken for frame, _ in step.frames])
                relabelled = {frame.stamp: frame for frame in frames}
                for step in taken:
                    output.write(step, relabelled)
    except (rosbag.ROSBagException, OSError, ValueError) as e:
        print('fuse_bag: %s' % e, file=sys.stderr)
        return 2
    output.report()
    return 0 if output.people else 1
