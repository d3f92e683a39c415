"""hri_sync.clock.ros_clock_state: the one ClockState <-> ClockModel
conversion.

Runs without ROS: where the generated hri_sync.msg cannot be imported
(``make unit`` does not source the workspace) a stand-in ClockState with
the message's fields takes its place.
"""
import importlib
import math
import sys
import types

import pytest

from hri_sync.clock.model import ClockModel, GlobalClock, OffsetMeasurement

FIELDS = ('client_id', 'ok', 'reason', 'local_ref', 'offset', 'drift',
          'uncertainty', 'samples', 'round_trip')


class StandInClockState:
    """hri_sync/ClockState's fields, nothing more."""

    def __init__(self, **kw):
        assert set(kw) <= set(FIELDS), set(kw) - set(FIELDS)
        for f in FIELDS:
            setattr(self, f, kw.get(f))


@pytest.fixture
def cs(monkeypatch):
    try:
        importlib.import_module('hri_sync.msg')
    except ImportError:
        monkeypatch.setitem(sys.modules, 'hri_sync.msg', types.SimpleNamespace(
            ClockState=StandInClockState))
    monkeypatch.delitem(sys.modules, 'hri_sync.clock.ros_clock_state',
                        raising=False)
    return importlib.import_module('hri_sync.clock.ros_clock_state')


def state(cs, **kw):
    fields = dict(client_id='a', ok=True, reason='', local_ref=1.7e9,
                  offset=-0.9, drift=2e-4, uncertainty=0.0003, samples=4)
    fields.update(kw)
    return cs.ClockState(**fields)


def test_round_trip_keeps_every_value(cs):
    model = ClockModel.from_state(1.7e9, -0.9, 2e-4, 0.0003)
    msg = cs.msg_from_model('a', model, samples=4)
    assert (msg.client_id, msg.ok, msg.reason, msg.samples) == ('a', True,
                                                                '', 4)
    back = cs.model_from_msg(msg)
    assert back.state() == model.state()


def test_a_holdover_is_published_with_the_grown_uncertainty(cs):
    c = GlobalClock(lambda: 1000.0, drift_bound=1e-4)
    c.add(OffsetMeasurement(980.0, 1.5, 0.002, 8))
    msg = cs.msg_from_model('a', c.snapshot(1000.0), 'holdover: ...', 1)
    assert msg.ok and msg.reason == 'holdover: ...'
    assert msg.local_ref == 980.0
    assert msg.uncertainty == pytest.approx(0.003, abs=1e-15)
    assert cs.model_from_msg(msg).uncertainty_at(2000.0) == msg.uncertainty


def test_a_model_not_ready_is_published_not_ok_with_finite_values(cs):
    msg = cs.msg_from_model('a', ClockModel(), 'did not answer')
    assert (msg.ok, msg.reason) == (False, 'did not answer')
    assert msg.uncertainty == cs.NO_MODEL_UNCERTAINTY
    assert all(math.isfinite(getattr(msg, f))
               for f in ('local_ref', 'offset', 'drift', 'uncertainty'))


def test_an_invalid_model_is_published_not_ok_with_the_reason(cs):
    msg = cs.msg_from_model('a', ClockModel(100.0, 0.0, 0.5, 0.001))
    assert not msg.ok
    assert msg.reason == 'invalid model: clock model drift=0.5 exceeds +/-0.01'


def test_a_state_without_a_model_is_refused_with_its_reason(cs):
    with pytest.raises(ValueError, match='^a has no clock model: did not '
                       'answer$'):
        cs.model_from_msg(state(cs, ok=False, reason='did not answer'))
    with pytest.raises(ValueError, match='no reason given'):
        cs.model_from_msg(state(cs, ok=False))


@pytest.mark.parametrize('bad, what', [
    ({'offset': math.nan}, 'offset=nan is not finite'),
    ({'drift': math.inf}, 'drift=inf is not finite'),
    ({'uncertainty': -0.001}, 'uncertainty=-0.001 is negative'),
    ({'local_ref': 1e10}, 'local_ref=10000000000.0 s is outside'),
    ({'offset': 4e9}, 'global time at local_ref'),
])
def test_unusable_values_are_refused_naming_the_sender(cs, bad, what):
    with pytest.raises(ValueError, match='^clock_state of a: clock model '):
        cs.model_from_msg(state(cs, **bad))
    with pytest.raises(ValueError, match=what):
        cs.model_from_msg(state(cs, **bad))
