"""The DPM on ROS: a sensor's samples in, results out.

The executable is ``nodes/data_process_module``.
"""
import dataclasses
import struct
import threading
import time

import genpy
import rospy
from diagnostic_msgs.msg import KeyValue

from hri_sync.msg import (CaptureCommand, CaptureData, ClientResult,
                          ClockState, DpmState)
from hri_sync.ros.params import ParamError, param, positive
from hri_sync.ros.stamps import header, secs, stamp
from hri_sync.ros.timers import after
from hri_sync.clock.ros_clock_state import model_from_msg
from hri_sync.ros.diagnostics import ProcessDiagnostics
from hri_sync.ros.inbox import Inbox, Throttle
from hri_sync.ros.msg_types import message_class
from hri_sync.ros.names import protocol_topic
from hri_sync.ros.outbox import Publisher
from hri_sync.data_process.ros_republisher import Republisher
from hri_sync.people.participant import summary_text
from hri_sync.sensors.base import HeaderStamped
from hri_sync.wire.vocabulary import (COMPLETION_MARGIN, DRIFT_BOUND,
                                      MIN_COVERAGE)
from hri_sync.data_process.dpm import STAMP_SOURCES, DataProcess
from hri_sync.client_process.liveness import SampleMeter
from hri_sync.data_process.health import noise_health
from hri_sync.data_process.orders import CommandGate
from hri_sync.data_process.processors import load_processor
from hri_sync.data_process.republish import a_time
from hri_sync.wire.protocol import Capture
from hri_sync.wire.validate import Context
from hri_sync.wire.vocabulary import CALIBRATION_NS, CALIBRATION_ROUND


class DataProcessModule:
    """Reads ~params and wires topics to a DataProcess."""

    def __init__(self):
        self.client_id = param('client_id', None, str, bool, 'a client id')
        path = param('processor', 'hri_sync.data_process.processors.CountMean',
                     str)
        params = param('processor_params', {}, dict)
        probe = self.make_core(path, params)
        self.throttle = Throttle(5.0)
        try:
            msg_class = message_class(probe.msg_type)
        except ValueError as e:
            raise ParamError('~processor reads %s: %s' % (probe.msg_type, e))
        if isinstance(probe, HeaderStamped) and not msg_class._has_header:
            raise ParamError('~processor reads %s, which has no '
                             'std_msgs/Header' % probe.msg_type)
        self.lock = threading.Lock()
        self.unstamped = 0
        self.refused, self.refused_reason = 0, ''  # samples refused
        # ~republish: false turns the captured topic off (benchmarks).
        self.republisher = Republisher(rospy.Publisher(
            'captured', msg_class, queue_size=100000), param(
                'republish_delay', 2.0, float, lambda x: x >= 0, '>= 0 s')) \
            if param('republish', True, bool) else None
        self.result_pub = Publisher(protocol_topic('client_result'),
                                    ClientResult, queue_size=10)
        self.calibration_pub = Publisher(
            protocol_topic(CALIBRATION_NS + '/client_result'), ClientResult,
            queue_size=10)
        # Clock states and capture orders only from this client's CPM,
        # validated (a forged far-off window would schedule a wake-up
        # beyond what a timer can sleep).
        self.inbox = Inbox()
        if rospy.has_param('~input'):
            raise ParamError('~input is gone: remap the sensor topic, '
                             '%s:=%s' % (probe.topic,
                                         rospy.get_param('~input')))
        input_topic = rospy.resolve_name(probe.topic)
        clock_topic = rospy.resolve_name('clock_state')
        command_topic = rospy.resolve_name('capture_command')
        self.diagnostics = ProcessDiagnostics(
            self.client_id, clock_topic, input_topic, command_topic,
            self.noise_health,
            lambda: dict(self.core.counts + self.gate.counts),
            self.inbox.summary)
        self.inbox.subscribe(clock_topic, ClockState, self.on_clock,
                             'cpm', client=self.client_id,
                             context=self.context)
        self.inbox.subscribe(command_topic, CaptureCommand,
                             self.on_command, 'cpm', client=self.client_id,
                             context=self.context, queue_size=10)
        # The CM's orders, which confirm the CPM's commands (a flood of
        # forged ones must not push a real one out of the queue).
        self.inbox.subscribe(protocol_topic('capture_data'), CaptureData,
                             self.on_order, 'cm', context=self.context,
                             queue_size=1000)
        # The CM's calibration window (nobody moving): this sensor's noise.
        self.inbox.subscribe(
            protocol_topic(CALIBRATION_NS + '/capture_data'), CaptureData,
            self.on_calibration, 'cm', context=lambda: dataclasses.replace(
                self.context(), calibration=True))
        self.msg_class = msg_class
        self.meter = SampleMeter()
        self.input_topic = input_topic
        # Relative: the CPM beside it, in the client's namespace, reads it.
        self.state_pub = Publisher('dpm_state', DpmState, queue_size=1)
        self.heartbeat_period = param('heartbeat_period', 0.5, float,
                                      positive, '> 0 s')
        rospy.Subscriber(input_topic, rospy.AnyMsg,
                         self.on_sample, queue_size=1000, tcp_nodelay=True)
        threading.Thread(target=self.poll, daemon=True).start()
        threading.Thread(target=self.heartbeat, daemon=True).start()

    def make_core(self, path, params):
        """The DataProcess and the CommandGate from ~params; returns the
        processor's probe."""
        try:
            probe = load_processor(path, params)
            self.core = DataProcess(
                lambda: load_processor(path, params),
                stamp_source=param('stamp_source', 'auto', str,
                                   lambda s: s in STAMP_SOURCES,
                                   ' or '.join(STAMP_SOURCES)),
                min_coverage=param('min_coverage', MIN_COVERAGE, float,
                                   lambda x: 0 <= x <= 1, 'within 0..1'),
                history=param('buffer', 2.0, float, positive, '> 0 s'),
                margin=param('completion_margin', COMPLETION_MARGIN, float,
                             lambda x: x >= 0, '>= 0 s'),
                drift_bound=param('drift_bound', DRIFT_BOUND, float,
                                  lambda x: 0 <= x < 1, '>= 0 s/s'),
                min_rate=param('min_rate', 0.0, float, lambda x: x >= 0,
                               '>= 0 Hz'),
                noise_chunk=param('noise_chunk', 1.0, float, positive,
                                  '> 0 s'),
                noise_span=param('noise_span', 600.0, float, positive,
                                 '> 0 s'),
                complete_on_last=param('complete_on_last', True, bool))
            # Commands only for rounds the CM ordered this client into.
            self.gate = CommandGate(self.client_id, param(
                'order_wait', 5.0, float, positive, '> 0 s'))
        except ValueError as e:
            raise ParamError(str(e))
        return probe

    def context(self):
        """What an incoming message is judged against: this client's
        global now (unknown before its clock state) and the local now."""
        local = time.time()
        with self.lock:
            clock = self.core.clock
        return Context(now=clock.to_global(local) if clock else None,
                       local_now=local)

    def on_clock(self, msg):
        self.diagnostics.clock.on_state(msg)
        try:
            model = model_from_msg(msg)
        except ValueError as e:     # keeps the last good model
            rospy.logwarn_throttle(10, '%s: %s', self.client_id, e)
            return
        with self.lock:
            self.core.set_clock(model)

    def on_sample(self, raw):
        # Subscribed as AnyMsg: the received bytes are republished as they
        # are, with the global stamp written in (no second serialization).
        local = time.time()
        self.diagnostics.on_sample()
        kind = getattr(raw, '_connection_header', {}).get('type')
        try:
            if kind not in (None, '*', self.msg_class._type):
                raise ValueError('a %s on a %s topic' % (
                    kind, self.msg_class._type))
            msg = self.msg_class().deserialize(raw._buff)
        except (genpy.DeserializationError, struct.error, ValueError) as e:
            with self.lock:
                self.core.refuse('unreadable')
                self.refused += 1
                self.refused_reason = str(e)
            rospy.logwarn_throttle(5, '%s: unreadable sample refused: %s',
                                   self.client_id, e)
            return
        with self.lock:
            self.meter.on_sample(local)
            step = self.core.on_sample(msg, local, raw._buff)
        self.handle(step)

    def heartbeat(self):
        """DpmState every ~heartbeat_period s: alive, and how the sensor
        delivers (samples, the last one's age, the recent rate)."""
        while not rospy.is_shutdown():
            with self.lock:     # now after any sample being added
                now = time.time()
                samples, age, rate = self.meter.state(now)
                refused, why = self.refused, self.refused_reason
            self.state_pub.publish(DpmState(
                header=header(now), client_id=self.client_id,
                input=self.input_topic, samples=min(samples, 2 ** 32 - 1),
                sample_age=age, rate=rate, refused=min(refused, 2 ** 32 - 1),
                refused_reason=why))
            time.sleep(self.heartbeat_period)

    def on_order(self, msg):
        order = Capture.from_msg(msg)
        with self.lock:
            confirmed = self.gate.order(msg.round, order.start, order.end,
                                        order.clients, time.time())
        for cmd in confirmed:
            self.open(cmd)

    def on_calibration(self, msg):
        """The CM's calibration window: captured when it names this
        client, its result on calibration/client_result."""
        order = Capture.from_msg(msg)
        if self.client_id not in order.clients:
            return
        rospy.loginfo('%s: calibration window [%.3f, %.3f): measuring the '
                      'sensor\'s noise', self.client_id, order.start,
                      order.end)
        self.open(order, self.core.calibrate)

    def noise_health(self):
        """The ``noise floor`` status of /diagnostics."""
        with self.lock:
            cal, base = self.core.calibration, self.core.baseline
            return noise_health(base is not None, cal.level, cal.start,
                                cal.failed, base.level()[0] if base
                                else float('nan'))

    def on_command(self, msg):
        with self.lock:
            confirmed = self.gate.command(msg.round, secs(msg.start),
                                          secs(msg.end), time.time())
        for cmd in confirmed:
            self.open(cmd)

    def open(self, cmd, calibrate=None):
        """A command the CM's order confirmed (or, with ``calibrate``,
        the calibration's order): its window opens."""
        with self.lock:
            step = calibrate(cmd.start, cmd.end) if calibrate else \
                self.core.open(cmd.round, cmd.start, cmd.end)
            clock = self.core.clock
            opened = cmd.round in self.core.windows
            if opened and self.republisher and not calibrate:
                self.republisher.hold(cmd.start, cmd.end)
        self.handle(step)
        if opened:
            after(clock.to_local(cmd.start) - time.time(), self.on_start,
                  cmd.round)

    def log_rejected(self, rejections):
        """Log capture commands the gate rejected (throttled by reason)."""
        for r in rejections:
            if self.throttle.due(r.reason):
                rospy.logwarn(
                    '%s: capture_command of round %d for [%.6f, %.6f) '
                    'rejected (%s): %s within ~order_wait %.1f s of it, so '
                    'it is not its CPM\'s (a forged one?); %d rejected so '
                    'far for this reason', self.client_id, r.command.round,
                    r.command.start, r.command.end, r.reason, r.why,
                    self.gate.wait, self.gate.counts[r.reason])

    def on_start(self, round_id):
        local = time.time()
        with self.lock:
            self.core.started(round_id, local)
        rospy.loginfo('%s: %s capture started', self.client_id,
                      'calibration' if round_id == CALIBRATION_ROUND
                      else 'round %d' % round_id)

    def poll(self):
        """Windows complete for lack of samples: checked every 5 ms from
        the first moment one can be (its end plus the margin), every
        0.1 s before."""
        while not rospy.is_shutdown():
            with self.lock:
                results = self.core.poll(time.time())
                wake = self.core.next_poll()
                rejected = self.gate.expire(time.time())
            for r in results:
                self.publish(r)
            self.log_rejected(rejected)
            time.sleep(0.1 if wake is None else
                       min(0.1, max(0.005, wake - time.time())))

    def handle(self, step):
        if step.captured and self.republisher:
            self.republisher.put(step.captured)
        for r in step.results:
            self.publish(r)
        for round_id in step.late:
            rospy.logwarn_throttle(
                5, '%s: a sample of round %d arrived after its result; not '
                'added (%d so far)', self.client_id, round_id,
                self.core.counts['late_after_result'])
        counts = dict(self.core.counts)
        unstamped = sum(n for k, n in counts.items()
                        if k in ('no_clock', 'no_device_stamp',
                                 'bad_device_stamp', 'unreadable')
                        or k in self.core.invalid)
        if unstamped > self.unstamped:
            self.unstamped = unstamped
            rospy.logwarn_throttle(
                5, '%s: samples refused so far: %s%s', self.client_id,
                ', '.join('%s %d' % kv for kv in sorted(counts.items())),
                '; the last invalid one: %s' % self.core.last_invalid
                if self.core.invalid else '')

    def publish(self, r):
        """The result, then its window's captured samples."""
        clock = self.core.clock     # made now (0: no clock model yet)
        pub = self.calibration_pub if r.calibration else self.result_pub
        pub.publish(ClientResult(
            header=header(clock.to_global(time.time()) if clock else None),
            round=r.round, client_id=self.client_id, status=r.status,
            capture_start=stamp(a_time(r.start)),
            capture_end=stamp(a_time(r.end)),
            frames=r.frames, frames_rejected=r.frames_rejected,
            frames_dropped=r.frames_dropped, coverage=r.coverage,
            first_frame_offset=r.first_frame_offset,
            wake_lateness=r.wake_lateness, value=r.value,
            timing_uncertainty=r.timing_uncertainty,
            noise_floor=r.noise_floor, noise_source=r.noise_source,
            diagnostics=[KeyValue(str(k), str(v))
                         for k, v in sorted(r.diagnostics.items())]))
        if self.republisher:
            self.republisher.release(r.start, r.end)
        d = r.diagnostics
        people = summary_text(d)
        if not r.calibration:
            self.diagnostics.results.record(
                r.round, r.status, d.get('error') or (
                    '%d frames, coverage %.2f' % (r.frames, r.coverage))
                + ('; ' + people if people else ''))
        log = rospy.logerr if r.status == ClientResult.ERROR else \
            rospy.loginfo
        log('%s: %s %s: %d frames (%d rejected, %d dropped, %s not '
            'stamped, %s late), coverage %.2f, value %.6g%s (noise floor '
            '%.4g %s), timing uncertainty %.3f ms (%s)', self.client_id,
            'calibration' if r.calibration else 'round %d' % r.round,
            r.status, r.frames, r.frames_rejected, r.frames_dropped,
            d.get('unstamped', 0), d.get('late_samples', 0), r.coverage,
            r.value, ' ' + d['unit'] if d.get('unit') else '', r.noise_floor,
            r.noise_source or 'unknown', r.timing_uncertainty * 1e3,
            d.get('error') or 'complete by %s' % d.get('completed_by'))
        if people:
            rospy.loginfo('%s: round %d %s (%s)', self.client_id, r.round,
                          people, d.get('participant_events'))
