"""hri_sync/ClockState <-> ClockModel: the one conversion, validated.

A ClockState carries a host's model at the instant it was published: its
``uncertainty`` is the bound then (grown in a holdover), and a model read
back from it does not grow further.
"""
import math

from hri_sync.msg import ClockState
from hri_sync.clock.model import ClockModel

NO_MODEL_UNCERTAINTY = 1e9  # s, published by a ClockState with ok false


def model_from_msg(msg):
    """The ClockModel a ClockState carries.

    Raises ValueError with the reason when the sender has no model (ok
    false) or a value is unusable (``ClockModel.from_state``).
    """
    if not msg.ok:
        raise ValueError('%s has no clock model: %s'
                         % (msg.client_id or 'the sender',
                            msg.reason or 'no reason given'))
    try:
        return ClockModel.from_state(msg.local_ref, msg.offset, msg.drift,
                                     msg.uncertainty)
    except ValueError as e:
        raise ValueError('clock_state of %s: %s'
                         % (msg.client_id or 'the sender', e))


def msg_from_model(client_id, model, reason='', samples=0,
                   round_trip=math.nan):
    """A ClockState of ``model``: ok when it is ready and valid;
    ``round_trip``: the NTP round trip of the measurement just made (s).

    A model that is not ready, or fails ``validate`` (then the reason
    says why), is published with ok false and finite placeholder values.
    """
    ok = model.ready
    if ok:
        try:
            model.validate()
        except ValueError as e:
            ok, reason = False, 'invalid model: %s' % e

    def finite(x):
        return x if math.isfinite(x) else 0.0
    return ClockState(
        client_id=client_id, ok=ok, reason=reason,
        local_ref=finite(model.local_ref), offset=finite(model.offset),
        drift=finite(model.drift),
        uncertainty=model.uncertainty if ok else NO_MODEL_UNCERTAINTY,
        samples=samples, round_trip=round_trip)
