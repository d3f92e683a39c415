"""hri_sync.ros.action_kinds: what action_client checks at start, and a
command's failure to begin (no master needed)."""
import roslib.message
import pytest

from hri_sync.robot.actions import ActionFailed, parse_action
from hri_sync.ros.action_kinds import CommandAction, filled, type_class


def test_a_type_that_is_not_installed_is_named():
    with pytest.raises(ValueError, match='type nope_msgs/Lamp not found'):
        type_class(roslib.message.get_message_class, 'nope_msgs/Lamp',
                   'action lamp')
    assert type_class(roslib.message.get_service_class, 'std_srvs/Trigger',
                      'x')._type == 'std_srvs/Trigger'


def test_fields_fill_the_message_or_are_refused():
    cls = roslib.message.get_message_class('geometry_msgs/PointStamped')
    msg = filled(cls, {'header': {'frame_id': 'lamp'}, 'point': {'x': 1.5}},
                 'action lamp')
    assert (msg.header.frame_id, msg.point.x, msg.point.y) == ('lamp', 1.5,
                                                               0.0)
    with pytest.raises(ValueError, match='action lamp: fields'):
        filled(cls, {'colour': 'red'}, 'action lamp')
    with pytest.raises(ValueError, match='do not fit'):
        filled(cls, {'point': {'x': 'far'}}, 'action lamp')


def test_a_command_that_cannot_start_fails_with_the_reason():
    logs = []
    spec = parse_action({'name': 'beep', 'at': 'window_start',
                         'command': ['/nonexistent/beep', '-q']})
    run = CommandAction(spec, None, lambda level, text: logs.append(level))
    assert logs == ['warn']             # not on PATH at start
    with pytest.raises(ActionFailed, match='No such file or directory'):
        run(spec)
