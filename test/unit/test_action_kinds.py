"""hri_sync.ros.action_kinds: what action_client checks at start, and a
command's failure to begin, its end and its timeout (no master
needed)."""
import os
import time

import roslib.message
import pytest

from hri_sync.robot.actions import (ActionFailed, Firing, StartReport,
                                    await_end, parse_action)
from hri_sync.ros import action_kinds
from hri_sync.ros.action_kinds import CommandAction, filled, type_class
from hri_sync.wire.vocabulary import Action, ActionEnd


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


def command(argv, timeout=None):
    """A CommandAction's spec and the Ending of the process it began."""
    item = {'name': 'beep', 'at': 'window_start', 'command': argv}
    if timeout is not None:
        item['timeout'] = timeout
    spec = parse_action(item)
    return spec, CommandAction(spec, time.time, lambda *a: None)(spec).ending


def test_a_command_ends_with_its_exit_status():
    spec, ok = command(['/bin/true'])
    spec, failed = command(['/bin/sh', '-c', 'exit 3'])
    assert ok.wait(30.0) and failed.wait(30.0)
    assert (ok.error, failed.error) == (None, 'exited with status 3')


def timed_out_sleeper(tmp_path, trap=''):
    """The end of a shell past its 0.5 s timeout, its background child
    gone; ``trap`` runs first in the shell."""
    pid_file = tmp_path / 'child'
    spec, ending = command(['/bin/sh', '-c', trap + 'sleep 300 & '
                            'echo $! > "$0"; wait', str(pid_file)],
                           timeout=0.5)
    start = StartReport(Firing(spec, 1, time.time()), time.time(), 0.0,
                        0.0, Action.OK, '', ending)
    end = await_end(start, time.time)
    assert end.status == ActionEnd.TIMEOUT
    child = int(pid_file.read_text())
    with pytest.raises(ProcessLookupError):
        for _ in range(300):            # until init reaps it
            os.kill(child, 0)
            time.sleep(0.01)
    return end


def test_a_command_past_its_timeout_is_killed_with_its_group(tmp_path):
    end = timed_out_sleeper(tmp_path)
    assert end.reason.endswith(': its process group ended on SIGTERM')


def test_a_command_ignoring_sigterm_is_killed_after_the_grace(
        tmp_path, monkeypatch):
    monkeypatch.setattr(action_kinds, 'TERM_GRACE', 0.3)
    # SIG_IGN is inherited: neither the shell nor its child ends on TERM.
    end = timed_out_sleeper(tmp_path, 'trap "" TERM; ')
    assert end.reason.endswith(': its process group killed (SIGKILL 0.3 s '
                               'after SIGTERM)')
