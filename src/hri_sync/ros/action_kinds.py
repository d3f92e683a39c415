"""The ROS side of hri_sync.robot.actions: each kind of action begun.

``executor(spec, now, log)`` builds at start what an action needs (its
message, service or action type by name, the message, request or goal
filled from the YAML fields, the publisher, proxy or action client); a
type that is not installed or a field it lacks raises ValueError naming
them.  Called at the scheduled time with the action, it begins it and
returns a note on the start (or None), or raises ActionFailed saying
why it did not begin.  ``now()`` is the global clock: a published
message with a std_msgs/Header whose stamp the YAML leaves 0 is stamped
with the global time it is sent at.
"""
import shutil
import subprocess
import threading
import warnings

import actionlib
import genpy
import roslib.message
import rospy
from actionlib_msgs.msg import GoalStatus

from hri_sync.robot.actions import ActionFailed
from hri_sync.ros.outbox import Publisher, Unsendable, check_sendable
from hri_sync.ros.params import stamp
from hri_sync.timing.vocabulary import Action


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
            return 'published on %s with no subscriber' % \
                self.pub.resolved_name
        return None


class ServiceAction:
    """Calls a service with one request; a response with ``success``
    false (std_srvs' Trigger and SetBool) is a failure too.  The proxy is
    persistent (no lookup and connection at each call); a call on a
    broken connection (the server restarted) is retried once on a new
    one."""

    def __init__(self, spec, now, log):
        what = 'action %s' % spec.name
        self.cls = type_class(roslib.message.get_service_class, spec.type,
                              what)
        self.request = filled(self.cls._request_class, spec.fields, what)
        self.target = spec.target
        self.proxy = None

    def call(self):
        if self.proxy is None:
            self.proxy = rospy.ServiceProxy(self.target, self.cls,
                                            persistent=True)
        try:
            return self.proxy.call(self.request)
        except (rospy.ServiceException, rospy.ROSException, OSError):
            self.proxy.close()
            self.proxy = None
            raise

    def __call__(self, spec):
        name = rospy.resolve_name(self.target)
        try:
            try:
                response = self.call()
            except (rospy.ServiceException, rospy.ROSException, OSError):
                response = self.call()
        except (rospy.ServiceException, rospy.ROSException, OSError) as e:
            raise ActionFailed('service %s: %s' % (name, e))
        if getattr(response, 'success', True) is False:
            raise ActionFailed('service %s answered success=false: %s' % (
                name, getattr(response, 'message', '')))
        return None


class ActionlibAction:
    """Sends one goal to an actionlib server; its result is logged."""

    def __init__(self, spec, now, log):
        what = 'action %s' % spec.name
        cls = type_class(roslib.message.get_message_class, spec.type, what)
        goal_cls = type_class(roslib.message.get_message_class,
                              spec.type[:-len('Action')] + 'Goal', what)
        self.goal = filled(goal_cls, spec.fields, what)
        self.server = rospy.resolve_name(spec.target)
        self.client = actionlib.SimpleActionClient(spec.target, cls)
        self.log = log
        self.name = spec.name

    def __call__(self, spec):
        # One check (it sleeps 10 ms only when the server is not there).
        if not self.client.wait_for_server(rospy.Duration(0.001)):
            raise ActionFailed('no actionlib server on %s' % self.server)
        self.client.send_goal(self.goal, done_cb=self.done)
        return None

    def done(self, state, result):
        text = GoalStatus.to_string(state)      # (set by actionlib)
        self.log('info' if state == GoalStatus.SUCCEEDED else
                 'warn', 'action %s: goal on %s ended %s' % (
                     self.name, self.server, text))


class CommandAction:
    """Runs a command (argv, no shell); its exit status is logged."""

    def __init__(self, spec, now, log):
        self.argv = list(spec.command)
        self.log = log
        self.name = spec.name
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
        threading.Thread(target=self.reap, args=(proc,), daemon=True).start()
        return None

    def reap(self, proc):
        code = proc.wait()
        if code:
            self.log('error', 'action %s: %s exited with status %d'
                     % (self.name, self.argv[0], code))


KINDS = {Action.PUBLISH: PublishAction, Action.SERVICE: ServiceAction,
         Action.ACTIONLIB: ActionlibAction, Action.COMMAND: CommandAction}


def executor(spec, now, log):
    """What begins ``spec`` (raises ValueError for a wrong type or
    fields)."""
    return KINDS[spec.kind](spec, now, log)
