"""A node's health on /diagnostics, through diagnostic_updater.

The statuses are computed by ``hri_sync.wire.health`` from plain values;
this module only publishes them.  ``NodeDiagnostics`` owns a
``diagnostic_updater.Updater`` (hardware id: the client id, or 'server'),
publishes every ``~diagnostic_period`` s (default 1) from a thread that
polls with sleeps (timed waits hang under libfaketime), and within 50 ms
of a change of a round tally it watches (``add_tally``).  Each status is named
``<node name>: <task>`` by diagnostic_updater, e.g. ``left/cpm: clock``.

``clock_check`` is the status of a ``SyncedClock``, ``HostClockCheck``
that of the host's system clock against the time server (its last SNTP
burst, chrony's estimate, the model's offset: ``clock.host_clock``),
``ClockStateWatch``
that of a clock read from a ClockState topic; ``round_diagnostics`` makes
a node's ``clock`` and ``rounds`` statuses, ``ProcessDiagnostics`` the
DPM's and ``DecisionDiagnostics`` the DM's;
``NodeDiagnostics.rejections`` adds the counts of rejected input (an
inbox's per-(topic, reason) ``summary``, a state machine's ``ignored``).
"""
import math
import socket
import threading
import time

import diagnostic_updater
import rospy

from hri_sync.clock.ros_clock_state import model_from_msg
from hri_sync.ros.names import protocol_topic
from hri_sync.ros.outbox import closed_at_shutdown
from hri_sync.ros.params import param, positive
from hri_sync.clock import host_clock
from hri_sync.clock.health import clock_health, clock_state_health
from hri_sync.data_process.health import result_tally
from hri_sync.data_process.orders import UNSCHEDULED
from hri_sync.decision.health import DecisionTally
from hri_sync.wire.health import ERROR, RateMeter, RejectionWatch

POLL = 0.05  # s between two looks at a pending update
STALE_STATE = 20.0  # s: a ClockState older than this is overdue (a CPM
#                     republishes it after every sync, 5 s apart by default)
# A DPM's counts of capture commands not taken (the rest: samples).
COMMAND_REASONS = ('duplicate_command', 'conflicting_command') + UNSCHEDULED


class NodeDiagnostics:
    """The /diagnostics statuses of one node: tasks returning a Health."""

    def __init__(self, hardware_id):
        self.period = param('diagnostic_period', 1.0, float, positive,
                            '> 0 s')
        self.updater = diagnostic_updater.Updater()
        self.updater.setHardwareID(hardware_id)
        self._tallies = []
        threading.Thread(target=self._run, daemon=True).start()

    def add(self, name, check):
        """Publish ``check()`` (a ``health.Health``) as status ``name``."""
        def run(stat):
            try:
                h = check()
            except Exception as e:  # a bug in a check must not stop the rest
                stat.summary(ERROR, 'diagnostic check failed: %r' % e)
                return stat
            stat.summary(h.level, h.message)
            for key, value in h.values:
                stat.add(key, value)
            return stat
        self.updater.add(name, run)

    def rejections(self, *sources, name='input', recent=60.0):
        """Status ``name``: rejected input messages, from ``sources``
        (callables returning ``{'<topic> <reason>': count}``), WARN while
        the total grew in the last ``recent`` s."""
        watch = RejectionWatch(recent)

        def counts():
            total = {}
            for source in sources:
                for key, n in source().items():
                    total[key] = total.get(key, 0) + n
            return total
        self.add(name, lambda: watch.health(counts(), time.monotonic()))

    def add_tally(self, name, tally):
        """Publish a ``health.RoundTally`` as status ``name``, and every
        status within 50 ms of each change of it (a round's event), from
        the publishing thread: the node never waits for a check."""
        self.add(name, tally.health)
        self._tallies.append(tally)

    def _run(self):
        due = time.monotonic() + self.period
        seen = None
        while not rospy.is_shutdown():
            time.sleep(POLL)
            versions = [t.version for t in self._tallies]
            if versions != seen or time.monotonic() >= due:
                seen = versions
                due = time.monotonic() + self.period
                with closed_at_shutdown():
                    self.updater.force_update()


def round_diagnostics(hardware_id, tally, synced_clock=None,
                      max_uncertainty=None):
    """A node's NodeDiagnostics with its ``clock`` (a SyncedClock's, if
    given; ``max_uncertainty`` its limit) and its ``rounds`` (``tally``)
    statuses."""
    diagnostics = NodeDiagnostics(hardware_id)
    if synced_clock is not None:
        diagnostics.add('clock', clock_check(synced_clock, max_uncertainty))
        diagnostics.add('host_clock', HostClockCheck(synced_clock).health)
    diagnostics.add_tally('rounds', tally)
    return diagnostics


def clock_check(synced_clock, max_uncertainty=None):
    """The status of a ``SyncedClock`` (``health.clock_health``) from its
    latest measurement, never waiting for one in progress; a good sync is
    overdue after three resync periods plus one NTP burst."""
    sync = synced_clock.sync
    stale_after = (3 * sync.resync_period
                   + synced_clock.exchanges * synced_clock.timeout)
    return lambda: clock_health(sync.latest, time.time(), max_uncertainty,
                                stale_after)


class HostClockCheck:
    """Status ``host_clock``: this host's system clock against the time
    server, from the SyncedClock's last SNTP burst (its local clock is the
    system clock), beside the model's offset and chrony's estimate
    (``chronyc -c tracking``, asked every ``~chrony_period`` s, default
    30, by a thread of its own: a check never waits for it). WARN above
    ``~system_clock_warn`` (5 ms), ERROR above ``~system_clock_error``
    (50 ms): docs/host_clocks.md says why."""

    def __init__(self, synced_clock):
        self.sync = synced_clock.sync
        self.warn = param('system_clock_warn', host_clock.WARN_OFFSET, float,
                          positive, '> 0 s')
        self.error = param('system_clock_error', host_clock.ERROR_OFFSET,
                           float, positive, '> 0 s')
        self.period = param('chrony_period', 30.0, float, positive, '> 0 s')
        self.host = socket.gethostname()
        self.chrony = None
        threading.Thread(target=self._poll_chrony, daemon=True).start()

    def _poll_chrony(self):
        while not rospy.is_shutdown():
            self.chrony = host_clock.chrony_tracking()
            due = time.monotonic() + self.period
            while time.monotonic() < due and not rospy.is_shutdown():
                time.sleep(POLL)

    def health(self):
        """The status now."""
        status = self.sync.latest
        last = self.sync.clock.measurements[-1:] if not status.error \
            else []
        now = time.time()
        return host_clock.health(host_clock.HostClock(
            self.host, last[0].offset if last else math.nan,
            last[0].delay if last else math.nan, status.error,
            status.model.offset_at(now) if status.ok else math.nan,
            self.chrony), self.warn, self.error)


class ClockStateWatch:
    """The health of a clock a node reads from a ClockState topic
    (``health.clock_state_health``): feed it every message."""

    def __init__(self, source, stale_after=STALE_STATE):
        self.source = source
        self.stale_after = stale_after
        self._last = None   # (model or None, reason, samples, received)

    def on_state(self, msg):
        """A ClockState arrived (also one with ok false, or invalid)."""
        try:
            model, reason = model_from_msg(msg), msg.reason
        except ValueError as e:
            model, reason = None, str(e)
        self._last = (model, reason, msg.samples, time.monotonic())

    def health(self):
        """The status now."""
        last = self._last
        if last is None:
            return clock_state_health(self.source, None, '', 0, time.time(),
                                      None)
        model, reason, samples, received = last
        return clock_state_health(self.source, model, reason, samples,
                                  time.time(), time.monotonic() - received,
                                  self.stale_after)


class ProcessDiagnostics:
    """A DPM's statuses: ``clock`` (its CPM's ClockState: call
    ``clock.on_state``), ``sensor`` (the rate samples arrive at on
    ``input_topic``: call ``on_sample``), ``results`` (its ClientResults
    by status: ``results.record``), ``noise floor`` (``noise()``, a
    ``data_process.health.noise_health``) and ``input`` (``counts()``, the
    DataProcess's {reason: n}: samples refused, and capture commands
    ignored or rejected, ``COMMAND_REASONS``; samples held while a device
    clock map settles are not refused), with the other ``sources`` of
    rejections (an inbox's ``summary``)."""

    def __init__(self, client_id, clock_topic, input_topic, command_topic,
                 noise, counts, *sources):
        self.clock = ClockStateWatch(clock_topic)
        self.sensor = RateMeter(input_topic)
        self.results = result_tally()
        diagnostics = NodeDiagnostics(client_id)
        diagnostics.add('clock', self.clock.health)
        diagnostics.add('sensor', lambda: self.sensor.health(
            time.monotonic()))
        diagnostics.add_tally('results', self.results)
        diagnostics.add('noise floor', noise)
        diagnostics.rejections(lambda: {
            '%s %s' % (command_topic if why in COMMAND_REASONS
                       else input_topic, why): n
            for why, n in counts().items() if why != 'settling'}, *sources)

    def on_sample(self):
        """A sample arrived."""
        self.sensor.observe(time.monotonic())


class DecisionDiagnostics:
    """The DM's statuses: ``clock`` (the server's ClockState: call
    ``clock.on_state``), ``decisions`` (``tally``, a
    ``health.DecisionTally``), ``noise floors`` (``noise()``, a
    ``health.noise_health``) and ``input`` (``counts()``,
    the RoundCollector's {reason: n}: capture orders and results not
    taken), with the other ``sources`` of rejections (an inbox's
    ``summary``)."""

    CAPTURE_REASONS = ('duplicate_round', 'conflicting_round', 'bad_window')

    def __init__(self, participants, clock_topic, noise, counts,
                 *sources):
        self.clock = ClockStateWatch(clock_topic)
        self.tally = DecisionTally(participants)
        diagnostics = NodeDiagnostics('server')
        diagnostics.add('clock', self.clock.health)
        diagnostics.add_tally('decisions', self.tally)
        diagnostics.add('noise floors', noise)
        capture, result = (protocol_topic(t) for t in
                           ('capture_data', 'client_result'))
        diagnostics.rejections(lambda: {
            '%s %s' % (capture if why in self.CAPTURE_REASONS
                       else result, why): n
            for why, n in counts().items()}, *sources)
