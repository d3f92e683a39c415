"""Replaying sensors on a client's global schedule (audio_sensor,
sensor_replay): a timeline that starts at one global instant, played at
the host times the client's clock model gives."""
import math
import os
import time

import rospkg
import rospy

from hri_sync.msg import ClockState
from hri_sync.clock.ros_clock_state import model_from_msg
from hri_sync.ros.inbox import Inbox
from hri_sync.ros.params import ParamError, param
from hri_sync.wire.validate import Context


def data_file(name, what):
    """A path as given, or a file of the package's data/sensors/."""
    if os.path.exists(name):
        return name
    path = os.path.join(rospkg.RosPack().get_path('hri_sync'), 'data',
                        'sensors', name)
    if os.path.exists(path):
        return path
    raise ParamError('%s %r: no such file, nor in data/sensors/'
                     % (what, name))


def start_instant():
    """The timeline's start, global epoch s: ``~start``, or the value of
    the param ``~start_param`` names (a relative name is searched up the
    namespace, so the sensors of a system share one), or now + 1 s."""
    name = param('start_param', '', str)
    if name:
        key = name if name.startswith('/') else rospy.search_param(name)
        if not key or not rospy.has_param(key):
            raise ParamError('~start_param names %s, which is not set'
                             % name)
        return float(rospy.get_param(key))
    start = param('start', 0.0, float, math.isfinite, 'epoch s')
    return start if start > 0 else math.ceil(time.time()) + 1.0


class GlobalSchedule:
    """Host times of timeline offsets: ``start + t`` on the global clock,
    converted with this client's clock model (its CPM's ClockState on
    ``clock_state``, validated), or taken as host time before it has
    one (a replay waits for it: ``wait_for_clock``)."""

    def __init__(self, client_id, start):
        self.start = start
        self.clock = None
        self.inbox = Inbox()
        self.inbox.subscribe('clock_state', ClockState, self.on_clock,
                             'cpm', client=client_id,
                             context=lambda: Context(local_now=time.time()))

    def on_clock(self, msg):
        try:
            self.clock = model_from_msg(msg)
        except ValueError as e:     # keeps the last good model
            rospy.logwarn_throttle(10, '%s: %s', rospy.get_name(), e)

    def wait_for_clock(self, timeout):
        """Wait up to ``timeout`` s for the client's clock model, so the
        replay does not jump by the clock's offset when it comes; True if
        it came."""
        deadline = time.monotonic() + timeout
        while self.clock is None and time.monotonic() < deadline \
                and not rospy.is_shutdown():
            time.sleep(0.05)
        if self.clock is None:
            rospy.logwarn('%s: no clock_state from the CPM after %.0f s: '
                          'replaying on the host clock', rospy.get_name(),
                          timeout)
        return self.clock is not None

    def local(self, t):
        """Host time of timeline offset ``t`` s."""
        g = self.start + t
        clock = self.clock
        return clock.to_local(g) if clock else g

    def offset_now(self):
        """The timeline offset (s) of the host's now."""
        clock = self.clock
        now = time.time()
        return (clock.to_global(now) if clock else now) - self.start

    @staticmethod
    def sleep_until(local):
        """Sleep until host time ``local``; False on shutdown."""
        while not rospy.is_shutdown():
            delay = local - time.time()
            if delay <= 0:
                return True
            time.sleep(min(delay, 0.2))
        return False


def start_round_when_delivering(clients, timeout, service=
                                '/control_module/start_round'):
    """Wait (up to ``timeout`` s) until every client's DPM reports samples
    from its sensor (``/<client>/dpm_state``: some, the last under 1 s
    old), then ask the CM for a round (its ~start_round service, with
    ``rounds:=0``) and return its reply, once the round is over (call it
    in a thread): a round started while a replay sensor is still starting
    would be refused by that client's CPM."""
    from std_srvs.srv import Trigger
    from hri_sync.msg import DpmState
    states = {}
    subs = [rospy.Subscriber('/%s/dpm_state' % c, DpmState,
                             lambda m, c=c: states.__setitem__(c, m))
            for c in clients]
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and not rospy.is_shutdown() and not (
            len(states) == len(clients) and all(
                m.samples > 0 and m.sample_age < 1.0
                for m in states.values())):
        time.sleep(0.1)
    for s in subs:
        s.unregister()
    rospy.wait_for_service(service, max(1.0, deadline - time.monotonic()))
    return rospy.ServiceProxy(service, Trigger)()
