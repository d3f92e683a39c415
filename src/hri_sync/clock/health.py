"""A host's clock on /diagnostics, from plain values (no ROS).

``clock_health``: a clock model kept against the time server;
``clock_state_health``: the clock a node reads from a ClockState.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from hri_sync.wire.health import ERROR, Health, OK, WARN, text


if TYPE_CHECKING:
    from hri_sync.wire.times import LocalTime
    from hri_sync.clock.model import ClockModel
    from hri_sync.clock.sync import ClockStatus


def clock_health(status: ClockStatus, local_now: LocalTime,
                 max_uncertainty: float | None = None,
                 stale_after: float | None = None,
                 near: float = 0.8) -> Health:
    """The health of a host's clock at local time ``local_now``.

    ``status`` is a ``ClockStatus`` (``model``, ``error``, ``samples``);
    ``max_uncertainty`` (s) is the limit past which the client NACKs
    (None: no limit), ``stale_after`` (s) how long a good sync may be
    ago before it is overdue (None: never).  ERROR: no model, or its
    uncertainty now exceeds the limit.  WARN: holdover (the last
    measurement failed), a sync overdue, or the uncertainty above
    ``near`` times the limit.  Else OK.
    """
    model = status.model
    synced = model.ready
    limit_ms = None if max_uncertainty is None else max_uncertainty * 1e3
    if synced:
        unc_ms = model.uncertainty_at(local_now) * 1e3
        since = local_now - model.local_ref
        drift_ppm = model.drift * 1e6
        offset_ms = model.offset_at(local_now) * 1e3
    else:
        unc_ms, since, drift_ppm, offset_ms = math.inf, math.nan, math.nan, \
            math.nan
    error = status.error
    if not synced:
        level = ERROR
        reason = 'not synced: %s' % (error or 'not measured yet')
    elif limit_ms is not None and unc_ms > limit_ms:
        level = ERROR
        reason = ('uncertainty %.3f ms exceeds its limit %.3f ms'
                  % (unc_ms, limit_ms))
        if error:
            reason += '; no good sync for %.1f s: %s' % (since, error)
    elif error:
        level = WARN
        reason = ('holdover: no good sync for %.1f s (%s); uncertainty '
                  '%.3f ms' % (since, error, unc_ms))
        if limit_ms is not None:
            reason += ' of %.3f ms' % limit_ms
    elif stale_after is not None and since > stale_after:
        level = WARN
        reason = ('last good sync %.1f s ago, more than %.1f s'
                  % (since, stale_after))
    elif limit_ms is not None and unc_ms > near * limit_ms:
        level = WARN
        reason = ('uncertainty %.3f ms near its limit %.3f ms'
                  % (unc_ms, limit_ms))
    else:
        level, reason = OK, ''
    if level == OK:
        message = 'synced: uncertainty %.3f ms' % unc_ms
        if limit_ms is not None:
            message += ' (limit %.3f ms)' % limit_ms
        message += ', drift %+.2f ppm' % drift_ppm
    else:
        message = reason
    return Health(level, message, (
        ('synced', text(synced)),
        ('reason', reason),
        ('uncertainty_ms', text(unc_ms)),
        ('max_uncertainty_ms', text(limit_ms)),
        ('since_last_sync_s', 'never' if math.isnan(since)
         else text(since, '%.1f')),
        ('drift_ppm', text(drift_ppm, '%+.3f')),
        ('offset_ms', text(offset_ms)),
        ('samples', text(status.samples)),
        ('last_error', error)))


def clock_state_health(source: str, model: ClockModel | None, reason: str,
                       samples: int, local_now: LocalTime,
                       age: float | None,
                       stale_after: float | None = None) -> Health:
    """The health of a clock a node reads from a ClockState (the DPM from
    its CPM, the DM from the server).

    ``model`` is the ClockModel it carries (None: none received yet, or
    one with ok false, then ``reason`` says why), ``samples`` its NTP
    bursts, ``age`` the s since the last ClockState arrived (the sender
    republishes after every sync), ``stale_after`` how old it may get
    (None: any age).  ERROR without a model, WARN when the ClockState is
    old or says holdover, else OK.
    """
    values = [('synced', text(model is not None))]
    if model is None:
        level = ERROR
        message = ('not synced: %s' % reason if reason
                   else 'no clock_state from %s yet' % source)
        unc, since, drift, offset = math.inf, math.nan, math.nan, math.nan
    else:
        unc = model.uncertainty_at(local_now) * 1e3
        since = local_now - model.local_ref
        drift = model.drift * 1e6
        offset = model.offset_at(local_now) * 1e3
        if stale_after is not None and age is not None \
                and age > stale_after:
            level = WARN
            message = ('no clock_state from %s for %.1f s, more than %.1f s'
                       % (source, age, stale_after))
        elif reason:
            level, message = WARN, reason
        else:
            level = OK
            message = ('synced: uncertainty %.3f ms, drift %+.2f ppm'
                       % (unc, drift))
    values += [
        ('reason', '' if level == OK else message),
        ('uncertainty_ms', text(unc)),
        ('since_last_sync_s', 'never' if math.isnan(since)
         else text(since, '%.1f')),
        ('drift_ppm', text(drift, '%+.3f')),
        ('offset_ms', text(offset)),
        ('samples', text(samples)),
        ('clock_state_age_s', 'never' if age is None else text(age, '%.1f'))]
    return Health(level, message, tuple(values))
