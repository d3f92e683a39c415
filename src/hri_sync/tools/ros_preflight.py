"""A site's messages gathered for the preflight check.

The executable is ``nodes/preflight``.
"""
import threading

import rospy
from diagnostic_msgs.msg import DiagnosticArray

from hri_sync.msg import ClockState
from hri_sync.ros.params import param
from hri_sync.clock import host_clock
from hri_sync.tools.preflight import Clock

TRACKER_KEYS = ('device_clock_offset_s', 'device_clock_drift_ppm',
                'device_clock_restarts', 'mean_arrival_delay_ms')


def server_param(name, default=None):
    """~name, else the running server's param, else default."""
    if not rospy.has_param('~' + name) and rospy.has_param(name):
        return rospy.get_param(name)
    return param(name.rsplit('/', 1)[-1], default)


class Preflight:
    """Counts and latest messages of the site, under one lock."""

    def __init__(self, clients, participants, robot_id, topic):
        self.lock = threading.Lock()
        self.clocks = {}
        self.sensor = {c: 0 for c in participants}
        self.device = {}
        self.host_clock = {}
        self.odom = 0
        self.counting = False
        self.topics = {c: rospy.resolve_name(topic % c)
                       for c in participants}
        self.subs = [rospy.Subscriber('%s/clock_state' % c, ClockState,
                                      self.on_clock) for c in clients]
        self.subs += [rospy.Subscriber(t, rospy.AnyMsg, self.on_sample, c)
                      for c, t in self.topics.items()]
        self.subs.append(rospy.Subscriber('/diagnostics', DiagnosticArray,
                                          self.on_diagnostics))
        if robot_id:
            self.subs.append(rospy.Subscriber('odom', rospy.AnyMsg,
                                              self.on_odom))

    def on_clock(self, msg):
        with self.lock:
            self.clocks[msg.client_id] = Clock(
                msg.ok, msg.reason, msg.uncertainty, msg.drift, msg.samples,
                msg.offset)

    def on_sample(self, _msg, client):
        with self.lock:
            if self.counting:
                self.sensor[client] += 1

    def on_odom(self, _msg):
        with self.lock:
            if self.counting:
                self.odom += 1

    def on_diagnostics(self, msg):
        # /diagnostics is global: only this system's trackers count.
        caller = getattr(msg, '_connection_header', {}).get('callerid', '')
        if not caller.startswith(rospy.get_namespace()):
            return
        for s in msg.status:
            # a tracker's status: "<ns>/<client>/<node>: sensor"
            node, _, task = s.name.partition(': ')
            if task == 'sensor' and node.count('/') >= 1:
                client = node.rsplit('/', 2)[-2]
                values = {v.key: v.value for v in s.values
                          if v.key in TRACKER_KEYS}
                with self.lock:
                    self.device[client] = values
            elif task == 'host_clock':
                # a CPM's: hardware id = its client id
                with self.lock:
                    self.host_clock[s.hardware_id] = {
                        v.key: v.value for v in s.values}

    def up(self, clients):
        with self.lock:
            return all(c in self.clocks for c in clients)
