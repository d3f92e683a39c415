"""A skeleton sensor on ROS: clips or a recording, on the global clock.

The executable is ``nodes/skeleton_sensor``.
"""
import math
import os
import time

import numpy as np
import rospkg
import rospy
from geometry_msgs.msg import Point, Quaternion

from hri_sync.control.calibration import host_window
from hri_sync.dance_off.joints import NUM_JOINTS
from hri_sync.dance_off.motion import MODES, load_motion
from hri_sync.msg import CaptureData, ClockState, Skeleton
from hri_sync.people.participant import numbers
from hri_sync.clock.ros_clock_state import model_from_msg
from hri_sync.ros.inbox import Inbox
from hri_sync.ros.names import protocol_topic
from hri_sync.ros.bags import read_skeletons
from hri_sync.ros.outbox import Publisher
from hri_sync.ros.params import ParamError, param, positive
from hri_sync.ros.stamps import stamp
from hri_sync.wire.protocol import Capture
from hri_sync.wire.validate import Context
from hri_sync.wire.vocabulary import CALIBRATION_NS
from hri_sync.dance_off.skeleton_source import (Perturbation, SkeletonSource,
                                                replay_schedule, tick_times)


def resolve_motion(name):
    """A motion path as given, or a clip in the package's data/motion/."""
    if os.path.exists(name):
        return name
    folder = os.path.join(rospkg.RosPack().get_path('hri_sync'), 'data',
                          'motion')
    for candidate in (name, name + '.npz'):
        path = os.path.join(folder, candidate)
        if os.path.exists(path):
            return path
    raise ParamError('~motion %r: no such file, nor a clip in %s'
                     % (name, folder))


class SkeletonSensor:
    """The ROS shell around SkeletonSource / a recorded stream."""

    def __init__(self):
        # Over 80 lines: every ~param of the sensor read and checked in turn
        # (source, motion, noise, drops, recording), then its topics.
        self.client_id = param('client_id', None, str, bool, 'a client id')
        # In NS/<client_id>/ (hri_sync.ros.names): publishes skeleton,
        # reads clock_state, both remappable.
        if rospy.has_param('~topic'):
            raise ParamError('~topic is gone: remap the topic, skeleton:=%s'
                             % rospy.get_param('~topic'))
        self.topic = rospy.resolve_name('skeleton')
        self.rate = param('rate', 20.0, float, positive, '> 0 Hz')
        phase = param('phase', -1.0, float,
                      lambda p: p < 1.0 / self.rate,
                      '< 1/rate s; negative: random')
        self.seed = param('seed', -1, int)
        self.rng = np.random.default_rng(None if self.seed < 0 else self.seed)
        self.phase = phase if phase >= 0 else \
            self.rng.uniform(0, 1 / self.rate)
        start_param = param('start_param', '', str)
        if start_param:
            # A relative name is looked up the namespace (the system's).
            key = start_param if start_param.startswith('/') else \
                rospy.search_param(start_param)
            if not key or not rospy.has_param(key):
                raise ParamError('~start_param names %s, which is not set'
                                 % start_param)
            rospy.set_param('~start', rospy.get_param(key))
        start = param('start', 0.0, float, math.isfinite, 'epoch s')
        self.start = start if start > 0 else time.time()
        bag = param('bag', '', str)
        self.drop = param('drop', 0.0, float, lambda p: 0 <= p < 1,
                          'within [0, 1)')
        self.noise = param('noise', 0.0 if bag else 0.003, float,
                           lambda x: x >= 0, '>= 0 m')
        self.nan_joints = param('nan_joints', 0.0, float,
                                lambda p: 0 <= p <= 1, 'within [0, 1]')
        self.stop_after = param('stop_after', -1.0, float)
        self.stop_from = param('stop_from', 'start', str,
                               lambda f: f in ('start', 'window'),
                               "'start' or 'window'")
        self.window_start = None     # global, the first window's start
        self.user_id = param('user_id', 1, int, lambda u: u >= 0, '>= 0')
        self.frame_id = param('frame_id', self.client_id + '_sensor', str)
        self.bystander = None
        clip = param('bystander', '', str)
        if clip:
            try:
                self.bystander = SkeletonSource(
                    load_motion(resolve_motion(clip)), noise=self.noise,
                    speed=param('bystander_speed', 1.0, float, positive,
                                '> 0'),
                    seed=int(self.rng.integers(1 << 31)))
            except ValueError as e:
                raise ParamError('~bystander: %s' % e)
        self.bystander_id = param('bystander_user_id', self.user_id + 1, int,
                                  lambda u: u >= 0 and u != self.user_id,
                                  '>= 0, not ~user_id')
        self.shift = self.vector('bystander_shift')
        self.step_shift = self.vector('bystander_step_shift')
        self.step_after = param('bystander_step_after', -1.0, float)
        # What a replayed bag shows in a calibration window (empty: the
        # bag plays on): a recording of this sensor's still scene.
        self.still = None
        calibration_bag = param('calibration_bag', '', str)
        if calibration_bag:
            self.still = read_skeletons(calibration_bag,
                                        param('bag_topic', '', str))[:2]
        self.pauses = []      # host [t0, t1) of the calibration windows
        # ~replay_from window: the bag or clip starts over at the first
        # capture window (global, set on its order), so round 1 captures
        # its beginning however long the start-up took.
        self.replay_from = param('replay_from', 'start', str,
                                 lambda f: f in ('start', 'window'),
                                 "'start' or 'window'")
        self.restart_at = None
        if bag:
            self.recorded, self.rel, bag_topic = read_skeletons(
                bag, param('bag_topic', '', str))
            self.perturb = Perturbation(
                self.noise, self.drop,
                seed=self.seed if self.seed >= 0 else None)
            source = '%s (%s, %d frames, %.1f s)' % (
                bag, bag_topic, len(self.recorded), self.rel[-1])
            self.source = None
        else:
            path = resolve_motion(param('motion', None, str, bool,
                                        'a BVH/.npz/.track file or clip'))
            hold = param('hold', -1.0, float)
            try:
                motion = load_motion(path)
                self.source = SkeletonSource(
                    motion, noise=self.noise, drop=self.drop,
                    speed=param('speed', 1.0, float, positive, '> 0'),
                    hold=hold if hold >= 0 else None,
                    offset=param('offset', 0.0, float),
                    mode=param('mode', 'pingpong', str,
                               lambda m: m in MODES, ' or '.join(MODES)),
                    confidence=param('confidence', 1.0, float,
                                     lambda c: 0 <= c <= 1, 'within 0..1'),
                    seed=(self.seed if self.seed >= 0
                          else int(self.rng.integers(1 << 31))))
            except ValueError as e:     # BvhError included: names the file
                raise ParamError(str(e))
            source = '%s (%.1f s at %.0f Hz%s)' % (
                path, motion.duration, motion.rate,
                ', held at %.2f s' % hold if hold >= 0 else '')
        self.clock = None
        self.pub = Publisher(self.topic, Skeleton, queue_size=100,
                             tcp_nodelay=True)
        # The clock model only from this client's CPM, valid at our now.
        self.inbox = Inbox()
        self.inbox.subscribe('clock_state', ClockState,
                             self.on_clock, 'cpm', client=self.client_id,
                             context=lambda: Context(local_now=time.time()))
        if (self.stop_after >= 0 or self.step_after >= 0) and \
                self.stop_from == 'window' or self.replay_from == 'window':
            self.inbox.subscribe(protocol_topic('capture_data'), CaptureData,
                                 self.on_capture, 'cm',
                                 context=self.global_context)
        self.inbox.subscribe(
            protocol_topic(CALIBRATION_NS + '/capture_data'), CaptureData,
            self.on_calibration, 'cm', context=lambda: Context(
                now=self.global_context().now, calibration=True))
        rospy.loginfo('%s: %s on %s at %.1f Hz, phase %.1f ms, start %.3f '
                      '(in %.1f s), noise %.1f mm, drop %.2f',
                      rospy.get_name(),
                      source, self.topic, self.rate, self.phase * 1e3,
                      self.start, self.start - time.time(),
                      self.noise * 1e3, self.drop)

    def on_clock(self, msg):
        try:
            self.clock = model_from_msg(msg)
        except ValueError as e:     # keeps the last good model
            rospy.logwarn_throttle(10, '%s: %s', rospy.get_name(), e)

    def global_context(self):
        """This client's global now (unknown before its clock state)."""
        clock = self.clock
        return Context(now=clock.to_global(time.time()) if clock else None)

    def on_calibration(self, msg):
        """The CM's calibration window: the person stands still in it (a
        motion pauses, a bag shows ~calibration_bag or plays on; a
        bystander pauses)."""
        order = Capture.from_msg(msg)
        if self.client_id not in order.clients:
            return
        t0, t1 = host_window(order, time.time(), self.clock)
        still = self.source is not None or self.still is not None
        if self.source is not None:
            self.source.pause(t0, t1)
        elif self.still is not None:
            self.pauses.append((t0, t1))
        if self.bystander is not None:      # a motion of its own: still
            self.bystander.pause(t0, t1)
        rospy.loginfo('%s: calibration window in %.1f s: %s for %.1f s',
                      rospy.get_name(), t0 - time.time(),
                      'stands still' if still else 'plays on', t1 - t0)

    @staticmethod
    def vector(name):
        """~name as an (x, y, z) offset in m (default none)."""
        v = param(name, [0.0, 0.0, 0.0], numbers, lambda v: len(v) == 3 and
                  all(math.isfinite(x) for x in v), '[dx, dy, dz] m')
        return np.array(v, dtype=float)

    def on_capture(self, msg):
        if self.window_start is not None:
            return
        order = Capture.from_msg(msg)
        self.window_start = order.start
        rospy.loginfo('%s: first window at %.3f (~stop_from, ~replay_from)',
                      rospy.get_name(), self.window_start)
        if self.replay_from == 'window':
            self.restart_at = order.start

    def after(self, t, delay):
        """True from ``delay`` s (< 0: never) after ~stop_from, at host
        time t."""
        if delay < 0:
            return False
        if self.stop_from == 'start':
            return t >= self.start + delay
        clock, start = self.clock, self.window_start
        return (start is not None and clock is not None
                and clock.to_global(t) >= start + delay)

    def silent(self, t):
        """True from ~stop_after s after ~stop_from, at host time t."""
        return self.after(t, self.stop_after)

    @staticmethod
    def skeleton(frames, shift=None):
        """The first of SensorFrames ``frames`` as a Skeleton."""
        pos = frames.positions[0] + (0.0 if shift is None else shift)
        return Skeleton(positions=[Point(*p) for p in pos],
                        orientations=[Quaternion(*q)
                                      for q in frames.orientations[0]],
                        confidence=frames.confidence[0].tolist())

    def publish(self, t, msg, user_id=None):
        """Stamp and send a frame taken at host time ``t``, then the
        bystander's of that instant."""
        msg.client_id = self.client_id
        msg.user_id = self.user_id if user_id is None else user_id
        msg.device_stamp = stamp(t)
        msg.header.frame_id = self.frame_id
        clock = self.clock
        msg.header.stamp = stamp(clock.to_global(t) if clock else t)
        if self.nan_joints > 0:
            for j in np.flatnonzero(self.rng.random(NUM_JOINTS)
                                    < self.nan_joints):
                msg.positions[j] = Point(math.nan, math.nan, math.nan)
        self.pub.publish(msg)
        if user_id is None and self.bystander is not None:
            shift = self.step_shift if self.after(t, self.step_after) \
                else self.shift
            frames = self.bystander.frames([t], self.start)
            self.publish(t, self.skeleton(frames, shift), self.bystander_id)

    @staticmethod
    def sleep_until(t):
        while not rospy.is_shutdown():
            delay = t - time.time()
            if delay <= 0:
                return True
            time.sleep(min(delay, 0.2))
        return False

    def run_motion(self):
        period = 1.0 / self.rate
        tick = tick_times(self.start, self.phase, self.rate, time.time(),
                          time.time() + 2 * period)[0]
        start = self.start          # the clip's
        while self.sleep_until(tick):
            if self.silent(tick):
                rospy.logwarn('%s: stopped sending (~stop_after)',
                              rospy.get_name())
                rospy.spin()
                return
            restart = self.restart(tick)
            if restart is not None:     # the ticks keep their phase
                start = restart
                self.source.restart(start)
            frames = self.source.frames([tick], start)
            # (a tick just before the window it started over at: not sent)
            if frames.stamps.size and tick >= start:
                self.publish(tick, self.skeleton(frames))
            tick += period
            if tick < time.time():   # overloaded: skip ahead, keep the phase
                tick += math.ceil((time.time() - tick) / period) * period

    def run_bag(self):
        origin = self.start + self.phase
        while origin is not None:
            origin = self.replay_bag(origin)

    def replay_bag(self, origin):
        """Replay the bag from host time ``origin``; the next origin when it
        starts over at the first window (~replay_from window), None once
        the node stops."""
        now = time.time()
        for rel, index in replay_schedule(self.rel):
            t = origin + rel
            for t0, t1 in [p for p in self.pauses if p[0] <= t]:
                # a calibration window: the still recording, then the bag
                # goes on from where it stopped
                self.pauses.remove((t0, t1))
                if not self.replay(self.still, t0, t1, max(t0, now)):
                    return None
                origin += t1 - t0
                t += t1 - t0
            restart = self.restart(t)
            if restart is None and t >= now and self.sleep_until(t):
                restart = self.restart(t)   # the order came while asleep
            if restart is not None:
                return restart + self.phase
            if t >= now and not self.replay_frame(self.recorded[index], t):
                return None

    def restart(self, t):
        """The first window's start (host time) when a frame sent at host
        time ``t`` would be stamped in it, after it or less than half a
        period (at ~rate) before it (~replay_from window: the replay
        starts over there, and none of its frames from before falls in the
        window, even where the DPM, mapping the frames' device stamps,
        places a frame a millisecond before the window a millisecond into
        it); else None."""
        clock, window = self.clock, self.restart_at
        if window is None or clock is None or \
                clock.to_global(t) < window - 0.5 / self.rate:
            return None
        self.restart_at = None
        origin = clock.to_local(window)
        rospy.loginfo('%s: the %s starts over at the first window '
                      '(~replay_from window), %+.3f s from now',
                      rospy.get_name(), 'clip' if self.source else 'bag',
                      origin - time.time())
        return origin

    def replay(self, recording, t0, t1, first):
        """Replay ``recording`` ((frames, times)) from host time ``t0``
        until ``t1``, its frames before ``first`` left out; False once
        the node stops."""
        frames, rel = recording
        for dt, index in replay_schedule(rel):
            if t0 + dt >= t1:
                return True
            t = t0 + dt
            if t >= first and not self.replay_frame(frames[index], t):
                return False
        return True

    def replay_frame(self, msg, t):
        """Send recorded frame ``msg`` at host time ``t`` (perturbed);
        False once the node stops or goes silent."""
        if not self.sleep_until(t):
            return False
        if self.silent(t):
            rospy.logwarn('%s: stopped sending (~stop_after)',
                          rospy.get_name())
            rospy.spin()
            return False
        if self.perturb.kept(1)[0]:
            pos = self.perturb.jitter([(p.x, p.y, p.z)
                                       for p in msg.positions])
            self.publish(t, Skeleton(positions=[Point(*p) for p in pos],
                                     orientations=list(msg.orientations),
                                     confidence=list(msg.confidence)))
        return True

    def run(self):
        if self.source is None:
            self.run_bag()
        else:
            self.run_motion()
