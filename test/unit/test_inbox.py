"""hri_sync.ros.inbox without a ROS master: senders, plain values,
throttled logs, admission, counting and callback errors."""
import math

import genpy
import pytest
from geometry_msgs.msg import Twist, Vector3
from std_msgs.msg import Header

from hri_sync.ros import inbox
from hri_sync.ros.inbox import Inbox, Senders, Throttle
from hri_sync.wire.validate import Context


def test_default_senders_follow_the_launch_files():
    s = Senders()
    assert s.names('cm') == {'/control_module'}
    assert s.names('dm') == {'/decision_module'}
    assert s.names('cpm', 'left') == {'/left/cpm', '/left', '/left/robot'}
    assert s.names('dpm', 'right') == {'/right/dpm'}
    assert '/robot1/kobuki_sim' in s.names('base', 'robot1')
    assert s.names('sensor', 'left') == {'/left/sensor', '/left/tracker'}


def test_senders_overridden_per_role_and_per_client():
    s = Senders({'cm': '/server/cm', 'clients': {
        'c': {'cm': ['/control_module', '/delay_sync_time']},
        'dj_rob': {'cpm': '/robot'}}})
    assert s.names('cm') == {'/server/cm'}
    assert s.names('cm', 'c') == {'/control_module', '/delay_sync_time'}
    assert s.names('cpm', 'dj_rob') == {'/robot'}
    assert s.names('cpm', 'left') == {'/left/cpm', '/left', '/left/robot'}


def test_senders_are_relative_to_the_system_namespace():
    s = Senders(ns='/lab1/')
    assert s.names('cm') == {'/lab1/control_module'}
    assert s.names('cpm', 'left') == {'/lab1/left/cpm', '/lab1/left',
                                      '/lab1/left/robot'}
    assert s.names('sensor', 'right') == {'/lab1/right/sensor',
                                          '/lab1/right/tracker'}
    assert s.names('robot') == {'/lab1/dj_rob'}
    # lab2's CM is not lab1's
    assert '/lab2/control_module' not in s.names('cm')
    s = Senders({'cm': 'control_module', 'dm': '/elsewhere/dm',
                 'clients': {'x': {'cpm': 'x_cpm'}}}, ns='/lab2')
    assert s.names('cm') == {'/lab2/control_module'}
    assert s.names('dm') == {'/elsewhere/dm'}
    assert s.names('cpm', 'x') == {'/lab2/x_cpm'}


@pytest.mark.parametrize('config', [
    {'cm': ''}, {'cm': []}, {'cm': [3]}, {'cm': '~cm'}, {'cm': '/'},
    {'clients': {'a': {'dm': ['x', '']}}}])
def test_senders_need_node_names(config):
    with pytest.raises(ValueError, match='needs node names'):
        Senders(config)


def test_senders_need_a_global_system_namespace():
    with pytest.raises(ValueError, match='must be global'):
        Senders(ns='lab1')


def test_unknown_role():
    with pytest.raises(ValueError, match='unknown role'):
        Senders().names('boss')


def test_plain_turns_a_message_into_plain_values():
    h = Header(seq=3, frame_id='f')
    h.stamp.secs, h.stamp.nsecs = 10, 500000000
    assert inbox.plain(h) == {'seq': 3, 'stamp': 10.5, 'frame_id': 'f'}
    t = Twist(linear=Vector3(1.0, 2.0, 3.0))
    assert inbox.plain(t) == {'linear': {'x': 1.0, 'y': 2.0, 'z': 3.0},
                              'angular': {'x': 0.0, 'y': 0.0, 'z': 0.0}}


def test_throttle_per_key():
    now = [0.0]
    th = Throttle(10.0, lambda: now[0])
    assert th.due('a') and th.due('b')
    assert not th.due('a')
    now[0] = 9.9
    assert not th.due('a')
    now[0] = 10.0
    assert th.due('a')


def twist(caller, x=0.1):
    msg = Twist(linear=Vector3(x, 0.0, 0.0))
    msg._connection_header = {'callerid': caller}
    return msg


def robot_inbox():
    box = Inbox(Senders({'robot': '/dj_rob'}), clock=lambda: 0.0)
    admit = box.gate('/mobile_base/commands/velocity', 'geometry_msgs/Twist',
                     'robot', None, Context, True)
    return box, admit


def test_gate_admits_the_rightful_sender_only():
    box, admit = robot_inbox()
    assert admit(twist('/dj_rob'))
    assert not admit(twist('/rostopic_123'))
    assert not admit(Twist())                   # no connection header
    assert box.accepted == {'/mobile_base/commands/velocity': 1}
    assert box.rejected == {
        ('/mobile_base/commands/velocity', 'wrong_sender'): 2}


def test_gate_rejects_bad_content_from_the_rightful_sender():
    box, admit = robot_inbox()
    assert not admit(twist('/dj_rob', math.nan))
    assert not admit(twist('/dj_rob', 1e9))
    assert box.rejected == {
        ('/mobile_base/commands/velocity', 'not_finite'): 1,
        ('/mobile_base/commands/velocity', 'out_of_range'): 1}


class Ack:
    """A stand-in for a SyncAck: a client id and a caller."""

    def __init__(self, client_id, caller):
        self.client_id = client_id
        self._connection_header = {'callerid': caller}


def test_keyed_sender_only_x_acks_for_x():
    box = Inbox(Senders(), clock=lambda: 0.0)
    admit = box.gate('/sync_ack', 'hri_sync/SyncAck', 'cpm',
                     lambda m: m.client_id, Context, False)
    assert admit(Ack('left', '/left/cpm'))
    assert admit(Ack('dj_rob', '/dj_rob'))
    assert not admit(Ack('left', '/right/cpm'))
    assert box.rejected == {('/sync_ack', 'wrong_sender'): 1}


class ClockState(genpy.Message):
    """hri_sync/ClockState's fields, without the generated module."""

    __slots__ = ['client_id', 'ok', 'reason', 'local_ref', 'offset',
                 'drift', 'uncertainty', 'samples', 'round_trip']
    _type = 'hri_sync/ClockState'

    def __init__(self, caller, **fields):
        super().__init__()
        values = dict(client_id='left', ok=True, reason='', local_ref=1e9,
                      offset=0.5, drift=0.0, uncertainty=0.001, samples=3,
                      round_trip=0.001)
        values.update(fields)
        for k, v in values.items():
            setattr(self, k, v)
        self._connection_header = {'callerid': caller}


def test_fixed_client_is_checked_in_the_content():
    box = Inbox(Senders(), clock=lambda: 0.0)
    admit = box.gate('/left/clock_state', 'hri_sync/ClockState', 'cpm',
                     'left', lambda: Context(local_now=1e9 + 1), True)
    assert admit(ClockState('/left/cpm'))
    assert not admit(ClockState('/left/cpm', client_id='right'))
    assert not admit(ClockState('/left/cpm', offset=math.nan))
    assert not admit(ClockState('/right/cpm'))
    assert box.rejected == {('/left/clock_state', 'wrong_client'): 1,
                            ('/left/clock_state', 'not_finite'): 1,
                            ('/left/clock_state', 'wrong_sender'): 1}


def test_callback_errors_are_counted_and_logged_once(caplog):
    box = Inbox(Senders(), clock=lambda: 0.0)
    calls = []

    def callback(msg):
        calls.append(msg)
        raise ZeroDivisionError('boom')
    for i in range(3):
        box.call('/t', callback, i)
    assert calls == [0, 1, 2]
    assert box.errors == {('/t', 'ZeroDivisionError'): 3}
    tracebacks = [r for r in caplog.records if 'Traceback' in r.getMessage()]
    assert len(tracebacks) == 1


def test_rejections_logged_throttled_per_reason(caplog):
    now = [0.0]
    box = Inbox(Senders(), clock=lambda: now[0])
    admit = box.gate('/cmd', 'geometry_msgs/Twist', 'robot', None, Context,
                     True)
    for _ in range(5):
        admit(twist('/forger'))
        admit(twist('/dj_rob', math.inf))
    lines = [r.getMessage() for r in caplog.records
             if 'rejected' in r.getMessage()]
    assert len(lines) == 2
    assert any('wrong_sender' in m and '/forger' in m for m in lines)
    assert any('not_finite' in m for m in lines)
    now[0] = 11.0
    admit(twist('/forger'))
    assert '6 rejected so far' in caplog.records[-1].getMessage()


def test_summary_for_diagnostics():
    box = Inbox(Senders(), clock=lambda: 0.0)
    admit = box.gate('/cmd', 'geometry_msgs/Twist', 'robot', None, Context,
                     True)
    admit(twist('/dj_rob'))
    admit(twist('/x'))
    box.call('/cmd', lambda m: 1 / 0, None)
    assert box.summary() == {'/cmd accepted': 1,
                             '/cmd callback_error ZeroDivisionError': 1,
                             '/cmd wrong_sender': 1}
