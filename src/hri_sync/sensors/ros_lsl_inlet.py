"""An LSL stream into ROS, stamped on the global clock.

The executable is ``nodes/lsl_inlet``.
"""
import math
import threading
import time

import pylsl
import rospy

from hri_sync.msg import LslSample
from hri_sync.ros.diagnostics import NodeDiagnostics
from hri_sync.ros.params import ParamError, param, positive
from hri_sync.ros.stamps import header
from hri_sync.sensors.lsl import (ClockBreak, CorrectionFit, LslStamper,
                                  StreamGaps, inlet_health)
from hri_sync.tools import lsl_io


class LslInlet:
    """Reads ~params; resolves, pulls, stamps and publishes."""

    def __init__(self):
        self.query = {k: param(k, '', str) for k in
                      ('name', 'type', 'source_id')}
        if not any(self.query.values()):
            raise ParamError('give ~name, ~type or ~source_id of the LSL '
                             'stream to read')
        self.lost_after = param('lost_after', 1.0, float, positive, '> 0 s')
        self.event_period = param('event_period', 0.5, float, positive,
                                  '> 0 s')
        self.tick_period = param('tick_period', 0.1, float, positive,
                                 '> 0 s')
        self.tick_lag = param('tick_lag', 0.1, float, lambda x: x >= 0,
                              '>= 0 s')
        self.pub = rospy.Publisher('lsl', LslSample, queue_size=1000)
        self.counts = {'samples': 0, 'dropped_clock': 0, 'lost': 0}
        self.inlet = self.info = None
        self.stamper = None
        self.lost = 'not resolved yet'
        self.last_event = self.last_tick = self.last_sample = 0.0
        self.last_correction = -math.inf
        self.gap_horizon = param('gap_horizon', 2.0, float, positive, '> 0 s')
        self.gaps = None        # StreamGaps, from the first connect on
        # The pulling thread updates what /diagnostics reads.
        self.lock = threading.Lock()
        NodeDiagnostics(param('client_id', rospy.get_namespace().strip(
            '/') or 'lsl', str)).add('lsl', self.health)

    def health(self):
        """The ``lsl`` status: the stream's deliveries, real gaps and
        mapping quality (``inlet_health``)."""
        with self.lock:
            if self.stamper is None:
                return inlet_health('', StreamGaps(0.0), CorrectionFit(),
                                    0.0, self.counts)
            return inlet_health(lsl_io.describe(self.info), self.gaps,
                                self.stamper.fit, pylsl.local_clock(),
                                self.counts)

    def event(self, kind, reason, now=None):
        """Publish an event (LOST, CLOCK_RESET, RECOVERED, TICK)."""
        now = time.time() if now is None else now
        self.pub.publish(LslSample(
            header=header(now), kind=kind,
            stream=self.info.name() if self.info else '', reason=reason,
            lsl_stamp=math.nan, stamp_error=0.0))
        if kind != LslSample.TICK:
            self.last_event = now
            log = rospy.loginfo if kind == LslSample.RECOVERED else \
                rospy.logwarn
            log('lsl_inlet: %s: %s', {
                LslSample.LOST: 'stream lost',
                LslSample.CLOCK_RESET: 'stream clock broken',
                LslSample.RECOVERED: 'stream recovered'}[kind], reason)

    def connect(self):
        """Resolve the stream and open an inlet (True when done)."""
        infos = lsl_io.resolve(self.query['name'], self.query['type'],
                               self.query['source_id'], timeout=1.0)
        if not infos:
            return False
        info = infos[0]
        inlet = pylsl.StreamInlet(info, max_buflen=10, recover=False)
        try:
            inlet.open_stream(5.0)
            fit = CorrectionFit()
            correction, remote, rtt = lsl_io.time_correction_ex(inlet, 5.0)
            fit.add(remote + correction, correction, rtt)
        except (pylsl.util.LostError, pylsl.util.TimeoutError) as e:
            rospy.logwarn('lsl_inlet: %s: could not open: %s',
                          lsl_io.describe(info), e)
            return False
        with self.lock:
            self.inlet, self.info = inlet, info
            self.stamper = LslStamper(fit)
            if self.gaps is None:
                self.gaps = StreamGaps(info.nominal_srate(),
                                       self.gap_horizon)
        self.last_sample = time.time()
        self.last_correction = time.time()
        rospy.loginfo('lsl_inlet: reading %s, offset %.6f s (rtt %.3f ms)',
                      lsl_io.describe(info), correction, rtt * 1e3)
        return True

    def update_correction(self):
        """Poll LSL's offset estimate; a new one goes into the fit."""
        if time.time() - self.last_correction < 0.25:
            return
        self.last_correction = time.time()
        correction, remote, rtt = lsl_io.time_correction_ex(self.inlet, 1.0)
        with self.lock:
            self.stamper.fit.add(remote + correction, correction, rtt)

    def publish_chunk(self, samples, stamps):
        """Stamp and publish pulled samples; a clock break drops them."""
        now_lsl = pylsl.local_clock()
        offset = lsl_io.wall_minus_lsl()
        strings = self.info.channel_format() == pylsl.cf_string
        stamped = []
        for values, lsl_stamp in zip(samples, stamps):
            was = self.stamper.broken
            try:
                with self.lock:
                    host, bound = self.stamper.stamp(lsl_stamp, now_lsl,
                                                     offset)
            except ClockBreak as e:
                self.counts['dropped_clock'] += 1
                if not was:
                    self.event(LslSample.CLOCK_RESET, '%s; its samples are '
                               'dropped until they map again' % e)
                continue
            if was:
                self.deliver(stamped, now_lsl, restart=True)
                stamped = []
                self.event(LslSample.RECOVERED, 'samples map again after '
                           '%d dropped (%s)' % (self.counts['dropped_clock'],
                                                was))
            stamped.append(lsl_stamp)
            self.counts['samples'] += 1
            self.pub.publish(LslSample(
                header=header(host), kind=LslSample.DATA,
                stream=self.info.name(), lsl_stamp=lsl_stamp,
                stamp_error=bound, nominal_rate=self.info.nominal_srate(),
                channels=[] if strings else [float(v) for v in values],
                markers=[str(v) for v in values] if strings else []))
        self.deliver(stamped, now_lsl)

    def deliver(self, stamps, now_lsl, restart=False):
        """The stamped samples of one pull to the StreamGaps; ``restart``:
        then a new sample clock (the stream's stamps broke)."""
        with self.lock:
            self.gaps.deliver(stamps, now_lsl)
            if restart:
                self.gaps.restart()

    def step(self):
        """One pull (or, while lost, one resolve attempt)."""
        now = time.time()
        if self.inlet is None:
            if self.connect():
                if self.counts['lost']:
                    self.event(LslSample.RECOVERED, 'resolved again: %s'
                               % lsl_io.describe(self.info))
                self.lost = ''
            elif now - self.last_event >= self.event_period and \
                    self.counts['lost']:
                self.event(LslSample.LOST, self.lost)
            return
        try:
            self.update_correction()
            # No timed wait: it hangs under libfaketime (a skewed client)
            # until data comes, and a stalled stream would never be seen.
            samples, stamps = self.inlet.pull_chunk(timeout=0.0)
        except pylsl.util.LostError as e:
            self.on_lost('the outlet is gone (%s)' % e)
            return
        if stamps:
            self.last_sample = now
            self.publish_chunk(samples, stamps)
        else:
            time.sleep(0.005)
        self.watch(now)

    def watch(self, now):
        """Silence, a broken clock's reminders, and the marker ticks."""
        silent = now - self.last_sample
        if self.info.nominal_srate() > 0 and silent > self.lost_after:
            self.on_lost('no sample for %.1f s from a %g Hz stream' % (
                silent, self.info.nominal_srate()))
        elif self.stamper.broken and \
                now - self.last_event >= self.event_period:
            self.event(LslSample.CLOCK_RESET, '%s; %d samples dropped' % (
                self.stamper.broken, self.counts['dropped_clock']))
        if self.info.nominal_srate() == 0 and \
                now - self.last_tick >= self.tick_period:
            self.last_tick = now
            self.event(LslSample.TICK, '', now - self.tick_lag)

    def on_lost(self, why):
        self.counts['lost'] += 1
        self.lost = '%s: %s' % (lsl_io.describe(self.info), why)
        self.event(LslSample.LOST, self.lost + '; resolving it again')
        self.inlet = None

    def spin(self):
        rospy.loginfo('lsl_inlet: resolving the LSL stream %s', ', '.join(
            '%s=%r' % kv for kv in sorted(self.query.items()) if kv[1]))
        while not rospy.is_shutdown():
            self.step()
