"""DJ Rob on a TurtleBot: its CPM, dance, gestures and safety watchdog.

The executable is ``nodes/turtlebot_gesture``.
"""
import collections
import math
import os
import threading
import time
import warnings

import rospy
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from std_msgs.msg import Float64

from hri_sync.msg import (ActionStart, Decision, Led, SafetyStop, Sound,
                          SyncTime)
from hri_sync.robot.choreography import Event
from hri_sync.robot.dj_rob import DANCE, Config, DjRob, float_list
from hri_sync.robot.geometry import yaw_of
from hri_sync.robot.kobuki import limits_from_params
from hri_sync.robot.music import load_track_info
from hri_sync.robot.safety import SafetyConfig, Watchdog
from hri_sync.client_process.ros_cpm import ClientProcess
from hri_sync.ros.inbox import Inbox
from hri_sync.ros.names import protocol_topic
from hri_sync.ros.outbox import Publisher, closed_at_shutdown
from hri_sync.ros.params import ParamError, param, positive
from hri_sync.ros.stamps import header, stamp
from hri_sync.ros.timers import start_timing, wait_for
from hri_sync.clock.truth import KeptGil, realtime, true_time, wait_until
from hri_sync.wire.validate import Context
from hri_sync.wire.vocabulary import MAX_UNCERTAINTY

# s before a start's spin that its thread takes the GIL and keeps it
# (clock.truth): while the cores are still free of other robots' spins.
HOLD = 0.02
LOG = {'info': rospy.loginfo, 'warn': rospy.logwarn, 'error': rospy.logerr}


def read_config():
    """The dance's and the gesture's Config from ~params."""
    margin = param('margin', 0.9, float)
    try:
        limits = limits_from_params(lambda name, default: param(
            name, default, float))
        limits.scaled(margin)                    # checks the margin
    except ValueError as e:
        raise ParamError(str(e))
    period = 1.0 / param('rate', 50.0, float, positive, '> 0 Hz')
    bearings = tuple(math.radians(b) for b in param(
        'participant_bearings', [30.0, -30.0], float_list,
        why='bearings in degrees, participant 1 first'))
    distance = param('participant_distance', 1.5, float,
                     lambda d: d >= 0, '>= 0 m (0: bearing only)')
    track = param('track', '', str)
    if track:
        try:
            info = load_track_info(track)
        except ValueError as e:
            raise ParamError('~track: %s' % e)
        beat, first_beat = info.beat_period, info.first_beat
    else:
        beat = 60.0 / param('bpm', 120.0, float, positive, '> 0')
        first_beat = 0.0
    return Config(
        bearings, distance if distance > 0 else None, limits, margin, beat,
        first_beat,
        step=param('step', 0.15, float, lambda s: s >= 0, '>= 0 m'),
        step_beats=param('step_beats', 2, int, lambda n: n >= 1, '>= 1'),
        approach=param('approach', 0.3, float, lambda s: s >= 0, '>= 0 m'),
        bobble=math.radians(param('head_bobble_deg', 20.0, float)),
        period=period)


def read_safety_config():
    """The watchdog's SafetyConfig from ~params (<= 0: a check off)."""
    def p(name, default):
        return param(name, default, float, math.isfinite, 'finite s')
    return SafetyConfig(
        clock_max_age=p('safety_clock_max_age', 12.0),
        max_uncertainty=p('max_uncertainty', MAX_UNCERTAINTY),
        odom_max_age=p('safety_odom_max_age', 0.5),
        max_lag=p('safety_max_lag', 0.5),
        linear_tolerance=p('safety_linear_tolerance', 0.1),
        angular_tolerance=p('safety_angular_tolerance', 0.5),
        heading_tolerance=p('safety_heading_tolerance', 0.2),
        path_tolerance=p('safety_path_tolerance', 0.05),
        decision_timeout=p('decision_timeout', 5.0))


class TurtlebotGesture:
    """Feeds hri_sync.robot.dj_rob and publishes what its jobs command."""

    def __init__(self):
        self.client_id = param('client_id', 'dj_rob', str, bool)
        config = read_config()
        odom_timeout = param('odom_timeout', 5.0, float, positive, '> 0 s')
        odom_max_age = param('odom_max_age', 1.0, float, positive, '> 0 s')
        self.start_spin, self.rt_priority = start_timing(
            self.client_id, 'moves may start late; grant rtprio or set '
                            '~realtime_priority 0')
        self.rob = DjRob(config, lambda: self.cpm.clock.now(),
                         time.monotonic, lambda level, text: LOG[level](text),
                         self.client_id, odom_max_age)
        self.period = config.period
        self.safety = Watchdog(read_safety_config(), time.time,
                               self.clock_model)
        self.pending = collections.deque()  # decision trips for the runner
        self.checked = self.last_moving = 0.0
        self.safety_pub = Publisher('~safety_stop', SafetyStop,
                                    queue_size=10, latch=True)

        # Synchronous (queue_size None): the command leaves from the
        # real-time thread at the start, not from rospy's writer thread.
        with warnings.catch_warnings():
            warnings.simplefilter('ignore')
            self.cmd_pub = rospy.Publisher('mobile_base/commands/velocity',
                                           Twist, queue_size=None,
                                           tcp_nodelay=True)
        self.bobble_pub = rospy.Publisher('~head_bobble', Float64,
                                          queue_size=10)
        self.led_pubs = {k: rospy.Publisher('mobile_base/commands/' + k,
                                            Led, queue_size=10)
                         for k in ('led1', 'led2')}
        self.sound_pub = rospy.Publisher('mobile_base/commands/sound',
                                         Sound, queue_size=10)
        self.start_pub = Publisher('~action_start', ActionStart,
                                   queue_size=10, latch=True)
        self.inbox = inbox = Inbox()
        self.cpm = ClientProcess(
            self.client_id, self.on_capture,
            lambda late: self.rob.on_late(late.round, late.end, late.reason),
            inbox)
        self.cpm.diagnostics.add('safety', self.safety.health)
        inbox.subscribe('odom', Odometry, self.on_odom, 'base',
                        client=self.client_id, queue_size=1)
        inbox.subscribe(protocol_topic('decision'), Decision,
                        self.on_decision, 'dm', context=self.context,
                        queue_size=10)
        # Before the CPM's: a running gesture yields before the ACK.
        inbox.subscribe(protocol_topic('sync_time'), SyncTime,
                        lambda m: self.rob.on_sync_time(m.round), 'cm',
                        context=self.context, queue_size=10)
        self.cpm.start()
        if not wait_for(lambda: self.rob.has_odom, odom_timeout, poll=0.05):
            rospy.logerr('%s: no nav_msgs/Odometry on %s within %.1f s: is '
                         'the base running (kobuki_sim, or kobuki_node on a '
                         'real Turtlebot)?  Until it comes, the turn to the '
                         'winner uses dead reckoning of the commands.',
                         self.client_id, rospy.resolve_name('odom'),
                         odom_timeout)
        threading.Thread(target=self.run, daemon=True).start()
        rospy.loginfo('%s: ready; beat %.3f s, participants at %s deg',
                      self.client_id, config.beat,
                      ', '.join('%+.0f' % math.degrees(b)
                                for b in config.bearings))

    def context(self):
        """The global now, once the clock is usable."""
        clock = self.cpm.clock
        return Context(now=clock.now() if clock.ready else None)

    def clock_model(self):
        """The global clock's model as last measured (None before the
        CPM)."""
        cpm = getattr(self, 'cpm', None)
        return None if cpm is None else cpm.synced_clock.sync.latest.model

    def global_now(self):
        """The global time, or None while the clock has no model."""
        clock = self.cpm.clock
        return clock.now() if clock.ready else None

    def on_capture(self, order):
        self.safety.expect_decision(order.round, order.end)
        self.rob.on_capture(order.round, order.start, order.end, order.lead)

    def on_decision(self, m):
        now = self.global_now()
        trip = None if now is None else self.safety.on_decision(
            m.round, now, m.header.stamp.to_sec() or None)
        if trip is not None:
            self.pending.append(trip)     # the runner stops the base
            return
        self.rob.on_decision(m.round, m.outcome, m.winner, m.reason)

    def on_odom(self, msg):
        t, p = msg.twist.twist, msg.pose.pose
        pose = (p.position.x, p.position.y, yaw_of(p.orientation))
        self.safety.on_odom(t.linear.x, t.angular.z, pose if all(
            map(math.isfinite, pose)) else None)
        try:
            self.rob.on_odom(*pose)
        except ValueError:
            rospy.logerr_throttle(5, '%s: odom with a non-finite pose '
                                  'ignored', self.client_id)

    def run(self):
        """Run the jobs in start order; between them, the safety checks.
        Polls with sleep: timed waits on locks hang under libfaketime."""
        while not rospy.core.is_shutdown_requested():
            job = self.rob.take()
            if job is None:
                # At rest, a dead clock (no motion starts) or stale
                # odometry is no reason to publish; a base that moves on
                # its own or a decision gone wrong is.
                trip = self.guard(None)
                if trip is not None and trip.new and trip.reason not in (
                        SafetyStop.CLOCK_DEAD, SafetyStop.ODOM_STALE):
                    self.stop(trip, None)
                time.sleep(0.01)
                continue
            try:
                with closed_at_shutdown(), realtime(self.rt_priority):
                    self.execute(job)   # topics closed at shutdown: ends
            finally:
                self.rob.done()

    def guard(self, job):
        """The safety check before a command of ``job`` (None: idle): the
        Trip that stops the base now, or None."""
        self.checked = time.time()
        trip = self.pending.popleft() if self.pending else None
        if trip is None:
            trip = self.safety.check(self.global_now())
        if trip is not None and job is not None and trip.round \
                and trip.round < job.round:
            rospy.logerr('%s: %s; the motion of round %d goes on',
                         self.client_id, trip.detail, job.round)
            return None
        return trip

    def execute(self, job):
        # The GIL is kept from HOLD s before the start to the first command.
        with KeptGil() as kept:
            trip = self.guard(job)
            run = None if trip is not None else self.rob.begin(job)
            if trip is None and (run is None or wait_until(
                    self.cpm.clock.now, run.start, spin=self.start_spin,
                    stop=rospy.is_shutdown, hold=self.start_spin + HOLD,
                    kept=kept) is None):
                return
            self.run_job(job, run, trip, kept)

    def run_job(self, job, run, trip, kept):
        """Command ``run`` from its start (now) to its end or a trip."""
        now = self.cpm.clock.now
        while trip is None and not rospy.is_shutdown():
            trip = self.guard(job)
            if trip is not None:
                break
            host = true_time()
            tick = run.tick()
            if tick is None:
                break
            self.command(*tick.twist)
            kept.release()
            if tick.first:
                # Robots starting at this instant on other real-time
                # threads get the core before this one's bookkeeping.
                os.sched_yield()
            if tick.first and job.kind == DANCE:
                self.start_pub.publish(ActionStart(
                    header=header(tick.now), round=job.round,
                    client_id=self.client_id, action=ActionStart.DANCE,
                    scheduled=stamp(job.scheduled),
                    offset=tick.now - job.scheduled,
                    true_time=stamp(host)))
                rospy.loginfo('%s: round %d: first dance command %.2f ms '
                              'after the scheduled start', self.client_id,
                              job.round, (tick.now - job.scheduled) * 1e3)
            if tick.bobble is not None:
                self.bobble_pub.publish(tick.bobble)
            self.fire(tick.events)
            wait_until(now, tick.next, spin=0.001, stop=rospy.is_shutdown)
        if trip is not None:
            self.stop(trip, job)
            self.fire([Event(0.0, k, Led.BLACK) for k in ('led1', 'led2')])
            return
        # The explicit zero at every stop (the base would otherwise keep
        # the last command for 0.6 s).
        self.command(0.0, 0.0)
        self.bobble_pub.publish(0.0)
        self.fire(run.finish())

    def command(self, linear, angular):
        """Publish a velocity command (cleared by the last ``guard``)."""
        msg = Twist()
        msg.linear.x, msg.angular.z = linear, angular
        self.cmd_pub.publish(msg)
        self.safety.on_command(linear, angular)
        if linear or angular:
            self.last_moving = self.checked

    def stop(self, trip, job):
        """Zero velocity now, and say why on ~safety_stop."""
        self.command(0.0, 0.0)
        stopped = time.time()
        self.bobble_pub.publish(0.0)
        onset = trip.onset
        if trip.round:          # a decision's onset is global
            model = self.clock_model()
            onset = model.to_local(onset) if model is not None \
                and model.ready else stopped
        round_id = trip.round or (job.round if job is not None else 0)
        self.safety_pub.publish(SafetyStop(
            header=header(self.global_now()), client_id=self.client_id,
            round=round_id, reason=trip.reason, detail=trip.detail,
            onset=onset, last_moving=self.last_moving, stopped=stopped,
            deadline=self.period))
        rospy.logerr('%s: safety stop (%s)%s: %s; zero velocity %.1f ms '
                     'after the onset', self.client_id, trip.reason,
                     ' in round %d' % round_id if round_id else '',
                     trip.detail, (stopped - onset) * 1e3)
        self.last_moving = 0.0

    def fire(self, events):
        for e in events:
            if e.kind == 'sound':
                self.sound_pub.publish(Sound(value=e.value))
            else:
                self.led_pubs[e.kind].publish(Led(value=e.value))
