"""The ROS side of hri_sync.robot.actions: each kind of action begun.

``executor(spec, now, log)`` builds at start what an action needs (its
message, service or action type by name, the message, request or goal
filled from the YAML fields, the publisher, the service's connection or
the action client); a type that is not installed or a field it lacks
raises ValueError naming them.  Called at the scheduled time with the
action, it begins it and returns a ``Begun`` (a note on the start, and
the ``Ending`` its end will be told to: none for a publish, which ends
when it is sent), or raises ActionFailed saying why it did not begin
(no service or actionlib server, the command not found).  The start is
never held up by the end: a service's answer is awaited on a thread of
its own, an actionlib result comes in a callback, a command's exit is
reaped by a thread.  ``now()`` is the global clock: a published message
with a std_msgs/Header whose stamp the YAML leaves 0 is stamped with the
global time it is sent at.
"""
import itertools
import os
import shutil
import signal
import subprocess
import threading
import warnings

import actionlib
import genpy
import rosgraph
import roslib.message
import rospy
from actionlib_msgs.msg import GoalStatus
from rospy.exceptions import TransportException
from rospy.impl.tcpros_base import TCPROSTransport
from rospy.impl.tcpros_service import TCPROSServiceClient
from rospy.impl.validators import ParameterInvalid

from hri_sync.robot.actions import ActionFailed, Begun, Ending
from hri_sync.ros.outbox import Publisher, Unsendable, check_sendable
from hri_sync.ros.stamps import stamp
from hri_sync.ros.timers import wait_for
from hri_sync.wire.vocabulary import Action


def type_class(getter, type_name, what):
    """The class of ``type_name`` (a message, service or action type)."""
    try:
        cls = getter(type_name)
    except (ValueError, ImportError) as e:
        cls, why = None, str(e)
    else:
        why = 'not found'
    if cls is None:
        raise ValueError('%s: type %s %s (is its package installed and '
                         'built, and the workspace sourced?)'
                         % (what, type_name, why))
    return cls


def filled(cls, fields, what):
    """An instance of message class ``cls`` with the YAML ``fields``,
    serialised once (a value of the wrong type fails now, not when it
    is due)."""
    msg = cls()
    try:
        genpy.message.fill_message_args(msg, [fields])
        check_sendable(msg)
    except (genpy.MessageException, ValueError, TypeError, KeyError) as e:
        raise ValueError('%s: fields %r do not fit %s: %s'
                         % (what, fields, cls._type, e))
    return msg


class PublishAction:
    """Publishes one message on a topic (synchronously, from the firing
    thread, so it leaves at the start)."""

    def __init__(self, spec, now, log):
        what = 'action %s' % spec.name
        cls = type_class(roslib.message.get_message_class, spec.type, what)
        self.msg = filled(cls, spec.fields, what)
        self.now = now
        self.stamped = cls._has_header and \
            self.msg.header.stamp.is_zero()
        with warnings.catch_warnings():
            warnings.simplefilter('ignore')      # queue_size None
            self.pub = Publisher(spec.target, cls, queue_size=None,
                                 tcp_nodelay=True)

    def __call__(self, spec):
        if self.stamped:
            self.msg.header.stamp = stamp(self.now())
        try:
            self.pub.publish(self.msg)
        except (Unsendable, rospy.ROSException) as e:
            raise ActionFailed('publish on %s: %s' % (self.pub.resolved_name,
                                                      e))
        if self.pub.get_num_connections() == 0:
            return Begun('published on %s with no subscriber'
                         % self.pub.resolved_name)
        return Begun()


# What a service's connection, request or answer can fail with.
CALL_ERRORS = (rospy.ServiceException, rospy.ROSException,
               TransportException, ParameterInvalid, OSError, ValueError)


class ServiceCall(Ending):
    """A request sent on ``transport``; aborted by closing it (which
    wakes the thread awaiting the answer)."""

    def __init__(self, now, transport):
        super().__init__(now)
        self.transport = transport

    def abort(self):
        self.transport.close()
        return 'its connection closed'


class ServiceAction:
    """Calls a service with one request: the start is the request sent
    (after connecting, if no kept connection is free), the end its
    answer; a response with ``success`` false (std_srvs' Trigger and
    SetBool) is a failure.  rospy's persistent ServiceProxy does the
    three in one blocking call, so its steps are taken here with its
    parts (TCPROSTransport, TCPROSServiceClient).  A connection whose
    call was answered is kept for the next; a kept one found closed when
    awaiting the answer (the server restarted) is replaced and the
    request sent again, once."""

    def __init__(self, spec, now, log):
        what = 'action %s' % spec.name
        self.cls = type_class(roslib.message.get_service_class, spec.type,
                              what)
        self.request = filled(self.cls._request_class, spec.fields, what)
        self.name = rospy.resolve_name(spec.target)
        self.now = now
        self.seq = itertools.count(1)
        self.lock = threading.Lock()
        self.idle = None        # a connection whose last call was answered

    def connect(self):
        """A new persistent connection to the service."""
        try:
            uri = rosgraph.Master(rospy.get_name()).lookupService(self.name)
        except rosgraph.MasterError:
            raise ActionFailed('service [%s] unavailable' % self.name)
        except OSError as e:
            raise ActionFailed('service %s: no master: %s' % (self.name, e))
        transport = TCPROSTransport(TCPROSServiceClient(
            self.name, self.cls, headers={'persistent': '1'}), self.name)
        try:
            host, port = rospy.core.parse_rosrpc_uri(uri)
            transport.connect(host, port, uri)
        except CALL_ERRORS as e:
            transport.close()
            raise ActionFailed('service %s: cannot connect: %s'
                               % (self.name, e))
        return transport

    def sent(self, transport=None):
        """``transport`` (None: a new connection) with the request sent
        on it."""
        if transport is None:
            transport = self.connect()
        try:
            transport.send_message(self.request, next(self.seq))
        except CALL_ERRORS as e:
            transport.close()
            raise ActionFailed('service %s: %s' % (self.name, e))
        return transport

    def __call__(self, spec):
        with self.lock:
            kept, self.idle = self.idle, None
        try:
            transport = self.sent(kept)
        except ActionFailed:
            if kept is None:
                raise
            transport = self.sent()     # the kept one was closed
        call = ServiceCall(self.now, transport)
        threading.Thread(target=self.answer, args=(call, transport is kept),
                         daemon=True).start()
        return Begun(ending=call)

    def receive(self, transport):
        responses = transport.receive_once()
        if len(responses) != 1:
            raise rospy.ServiceException('%d responses' % len(responses))
        return responses[0]

    def answer(self, call, kept):
        """Awaits the answer to ``call`` (its own thread)."""
        note = ''
        try:
            try:
                response = self.receive(call.transport)
            except CALL_ERRORS:
                if not kept or call.wait(0):
                    raise
                call.transport.close()
                call.transport = self.sent()
                note = 'sent again on a new connection: the kept one was ' \
                    'closed'
                response = self.receive(call.transport)
        except ActionFailed as e:       # no new connection
            call.finish(str(e))
            return
        except CALL_ERRORS as e:
            call.transport.close()
            call.finish('service %s: %s' % (self.name, e))
            return
        error = None
        if getattr(response, 'success', True) is False:
            error = 'service %s answered success=false: %s' % (
                self.name, getattr(response, 'message', ''))
        spare = call.transport      # kept for the next call, if free
        if call.finish(error, note):
            with self.lock:
                spare, self.idle = self.idle, spare
        if spare is not None:
            spare.close()


class GoalRun(Ending):
    """A goal sent; its end is its handle's DONE transition; aborted by
    cancelling the goal."""

    def __init__(self, now, name, server, log):
        super().__init__(now)
        self.name, self.server, self.log = name, server, log
        self.handle = None

    def transition(self, handle):
        if handle.get_comm_state() != actionlib.CommState.DONE:
            return
        state = handle.get_goal_status()
        text = GoalStatus.to_string(state)      # (set by actionlib)
        if state == GoalStatus.SUCCEEDED:
            self.log('info', 'action %s: goal on %s result: %s' % (
                self.name, self.server, handle.get_result()))
            self.finish()
        else:
            self.finish('goal on %s ended %s%s' % (
                self.server, text, ': ' + handle.get_goal_status_text()
                if handle.get_goal_status_text() else ''))

    def abort(self):
        self.handle.cancel()
        return 'goal cancelled'


class ActionlibAction:
    """Sends one goal to an actionlib server; it ends with the goal: OK
    when it SUCCEEDED (its result is logged), else FAILED with the
    goal's state.  Each goal has its handle (actionlib.ActionClient), so
    a goal still running when the next is sent keeps its own end."""

    def __init__(self, spec, now, log):
        what = 'action %s' % spec.name
        cls = type_class(roslib.message.get_message_class, spec.type, what)
        goal_cls = type_class(roslib.message.get_message_class,
                              spec.type[:-len('Action')] + 'Goal', what)
        self.goal = filled(goal_cls, spec.fields, what)
        self.server = rospy.resolve_name(spec.target)
        self.client = actionlib.ActionClient(spec.target, cls)
        self.now = now
        self.log = log
        self.name = spec.name

    def __call__(self, spec):
        # One check (it sleeps 10 ms only when the server is not there).
        if not self.client.wait_for_server(rospy.Duration(0.001)):
            raise ActionFailed('no actionlib server on %s' % self.server)
        run = GoalRun(self.now, self.name, self.server, self.log)
        run.handle = self.client.send_goal(self.goal,
                                           transition_cb=run.transition)
        return Begun(ending=run)


TERM_GRACE = 2.0      # s an aborted command's group has after SIGTERM


def group_alive(pgid):
    """Whether a process of the group ``pgid`` still exists."""
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:     # there, but another user's now
        pass
    return True


class CommandRun(Ending):
    """A command's process; its end is its exit; aborted by stopping its
    process group (it runs in a session of its own): SIGTERM, then
    SIGKILL if the group is still there ``TERM_GRACE`` s later."""

    def __init__(self, now, proc):
        super().__init__(now)
        self.proc = proc
        threading.Thread(target=self.reap, daemon=True).start()

    def reap(self):
        code = self.proc.wait()
        if code == 0:
            self.finish()
        elif code < 0:
            self.finish('killed by signal %d' % -code)
        else:
            self.finish('exited with status %d' % code)

    def abort(self):
        pgid = self.proc.pid
        try:
            os.killpg(pgid, signal.SIGTERM)
        except OSError as e:
            return 'its process group not signalled: %s' % e
        wait_for(lambda: not group_alive(pgid), TERM_GRACE, 0.02)
        try:
            os.killpg(pgid, signal.SIGKILL)
        except ProcessLookupError:
            return 'its process group ended on SIGTERM'
        except OSError as e:
            return 'its process group not killed: %s' % e
        return 'its process group killed (SIGKILL %g s after SIGTERM)' \
            % TERM_GRACE


class CommandAction:
    """Runs a command (argv, no shell, its own session); it ends with
    its exit: OK on status 0, else FAILED with the status."""

    def __init__(self, spec, now, log):
        self.argv = list(spec.command)
        self.now = now
        if shutil.which(self.argv[0]) is None:
            log('warn', 'action %s: %s is not an executable on PATH now: '
                'it will fail unless it appears' % (spec.name, self.argv[0]))

    def __call__(self, spec):
        try:
            proc = subprocess.Popen(self.argv, stdin=subprocess.DEVNULL,
                                    start_new_session=True)
        except (OSError, ValueError) as e:
            raise ActionFailed('command %s: %s' % (
                self.argv[0], getattr(e, 'strerror', None) or e))
        return Begun(ending=CommandRun(self.now, proc))


KINDS = {Action.PUBLISH: PublishAction, Action.SERVICE: ServiceAction,
         Action.ACTIONLIB: ActionlibAction, Action.COMMAND: CommandAction}


def executor(spec, now, log):
    """What begins ``spec`` (raises ValueError for a wrong type or
    fields)."""
    return KINDS[spec.kind](spec, now, log)
