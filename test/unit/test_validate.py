"""hri_sync.wire.validate: every incoming message type's boundary check."""
import dataclasses
import inspect
import math
import os
import re

import pytest

from hri_sync.wire import validate as v
from hri_sync.wire.validate import Context, Limits, Rejected

NOW = 1_700_000_000.0
CTX = Context(now=NOW, local_now=NOW - 2.0, round=5)
MSG_DIR = os.path.join(os.path.dirname(__file__), '..', '..', 'msg')


def hdr(t, frame_id=''):
    """A std_msgs/Header as the inbox gives it (plain values)."""
    return {'seq': 7, 'stamp': t, 'frame_id': frame_id}


def good(msg_type):
    """Fields of an acceptable message of ``msg_type`` against CTX."""
    joints = v.NUM_JOINTS
    header = hdr(NOW - 0.01, 'sensor')
    return {
        'hri_sync/SyncTime': dict(header=hdr(NOW - 0.001), round=5),
        'hri_sync/SyncAck': dict(
            header=hdr(NOW - 0.001), round=5, client_id='left', ok=True,
            reason='', offset=1.7, uncertainty=0.0004, drift=2e-4,
            sync_received=NOW - 0.002),
        'hri_sync/CaptureData': dict(header=hdr(NOW), round=5, str_aft=0.3,
                                     dur=60.0, clients=['left', 'right']),
        'hri_sync/CaptureCommand': dict(header=hdr(NOW - 0.01), round=5,
                                        start=NOW + 0.3, end=NOW + 60.3),
        'hri_sync/RoundStatus': dict(
            header=hdr(NOW), round=5, state='capturing', reason='',
            acked=['left'], refused=[], missing=['right']),
        'hri_sync/ClockState': dict(
            client_id='left', ok=True, reason='', local_ref=NOW - 3.0,
            offset=2.0, drift=1e-4, uncertainty=0.0005, samples=4,
            round_trip=0.0004),
        'hri_sync/ClientResult': dict(
            header=hdr(NOW - 0.5), round=5, client_id='left', status='ok',
            capture_start=NOW - 61, capture_end=NOW - 1, frames=1200,
            frames_rejected=0, frames_dropped=2, coverage=0.99,
            first_frame_offset=0.01, wake_lateness=0.004, value=3.2,
            timing_uncertainty=0.0002, noise_floor=0.05,
            diagnostics=[{'key': 'terms', 'value': '1199'}],
            noise_source='calibration'),
        'hri_sync/DpmState': dict(
            header=dict(header, stamp=NOW - 2.0), client_id='left',
            input='/left/skeleton', samples=40, sample_age=0.04, rate=20.0,
            refused=0, refused_reason=''),
        'hri_sync/Decision': dict(
            header=hdr(NOW), round=5, outcome='winner', winner=2,
            clients=['left', 'right'], scores=[1.5, 3.2],
            reason='right wins', window_end=NOW - 1,
            timing_uncertainty=0.0002, noise_floors=[0.03, 0.05]),
        'hri_sync/Skeleton': dict(
            header=header, client_id='left', user_id=1,
            device_stamp=12.5,
            positions=[{'x': 0.1, 'y': 0.2, 'z': 2.0}] * joints,
            orientations=[(0.0, 0.0, 0.0, 1.0)] * joints,
            confidence=[1.0] * joints, frame_index=31, frames_skipped=2,
            sources=['left', 'robot1/cam']),
        'hri_sync/Sample': dict(header=header, index=3, value=0.5),
        'hri_sync/ActionStart': dict(
            header=hdr(NOW - 0.99), round=5, client_id='dj_rob',
            action='dance', scheduled=NOW - 1.0, offset=0.01,
            true_time=NOW - 0.99, kind='', event='', status='', reason='',
            tolerance=0.0, local_time=0.0),
        'hri_sync/ActionEnd': dict(
            header=hdr(NOW - 0.5), round=5, client_id='actions',
            action='cheer', kind='service', event='decision', status='ok',
            reason='', started=NOW - 0.6, duration=0.1, timeout=5.0),
        'hri_sync/Beat': dict(header=hdr(NOW), round=5, index=4,
                              bar_beat=0, bpm=120.0),
        'hri_sync/Led': dict(value=1),
        'hri_sync/Sound': dict(value=6),
        'geometry_msgs/Twist': dict(linear=(0.2, 0.0, 0.0),
                                    angular={'x': 0, 'y': 0, 'z': 0.5}),
        'nav_msgs/Odometry': dict(
            header=header, child_frame_id='base_footprint',
            pose={'pose': {'position': (1.0, 2.0, 0.0),
                           'orientation': (0.0, 0.0, 0.0, 1.0)},
                  'covariance': [0.0] * 36},
            twist={'twist': {'linear': (0.1, 0, 0), 'angular': (0, 0, 0.3)},
                   'covariance': [0.0] * 36}),
    }[msg_type]


def rejected(msg_type, ctx=CTX, **change):
    """The Rejected raised for good(msg_type) with ``change``."""
    fields = dict(good(msg_type), **change)
    with pytest.raises(Rejected) as e:
        v.check(msg_type, fields, ctx)
    return e.value


@pytest.mark.parametrize('msg_type', sorted(v.VALIDATORS))
def test_good_messages_pass(msg_type):
    v.check(msg_type, good(msg_type), CTX)


def msg_fields(path):
    """Field names of a .msg file (constants and comments skipped)."""
    out = []
    with open(path) as f:
        for line in f:
            line = line.split('#')[0].strip()
            if line and '=' not in line:
                out.append(line.split()[1])
    return out


@pytest.mark.parametrize('msg_type', sorted(
    t for t in v.VALIDATORS if t.startswith('hri_sync/')))
def test_validators_take_exactly_the_message_fields(msg_type):
    fields = msg_fields(os.path.join(MSG_DIR, msg_type.split('/')[1]
                                     + '.msg'))
    params = inspect.signature(v.VALIDATORS[msg_type]).parameters
    required = [p for p, d in params.items()
                if d.default is inspect.Parameter.empty and p != 'ctx']
    assert sorted(required) == sorted(fields)


def test_every_hri_sync_message_a_node_subscribes_has_a_validator():
    nodes = os.path.join(os.path.dirname(__file__), '..', '..', 'nodes')
    ros = os.path.join(os.path.dirname(__file__), '..', '..', 'src',
                       'hri_sync', 'ros')
    subscribed = set()
    for folder in (nodes, ros):
        for name in os.listdir(folder):
            path = os.path.join(folder, name)
            if not os.path.isfile(path):
                continue
            with open(path) as f:
                subscribed |= set(re.findall(
                    r'Subscriber\([^,]+,\s*([A-Z]\w+)', f.read()))
    known = {t.split('/')[1] for t in v.VALIDATORS}
    ours = {f[:-len('.msg')] for f in os.listdir(MSG_DIR)}
    assert subscribed & ours <= known


@pytest.mark.parametrize('t,reason', [
    (math.nan, 'time_not_finite'), (math.inf, 'time_not_finite'),
    (-1.0, 'time_not_positive'), (0.0, 'time_not_positive'),
    (2.0 ** 32, 'time_unrepresentable'), (1e12, 'time_unrepresentable'),
    ('12', 'not_a_number'), (True, 'not_a_number')])
def test_bad_times(t, reason):
    with pytest.raises(Rejected) as e:
        v.time_value(t, 'stamp')
    assert e.value.reason == reason
    assert e.value.field == 'stamp'
    assert 'stamp' in str(e.value)


def test_zero_time_only_where_the_contract_allows_it():
    assert v.time_value(0.0, 'stamp', optional=True) == 0.0
    for kind in ('Decision', 'RoundStatus', 'ClientResult'):
        v.check('hri_sync/' + kind, dict(good('hri_sync/' + kind),
                                         header=hdr(0.0)), CTX)
    for kind in ('SyncTime', 'SyncAck', 'CaptureData', 'CaptureCommand',
                 'ActionStart', 'ActionEnd', 'Beat'):
        e = rejected('hri_sync/' + kind, header=hdr(0.0))
        assert (e.reason, e.field) == ('time_not_positive', 'header.stamp')


@pytest.mark.parametrize('msg_type', [
    'hri_sync/' + k for k in ('SyncTime', 'SyncAck', 'CaptureData',
                              'CaptureCommand', 'RoundStatus',
                              'ClientResult', 'Decision', 'ActionStart',
                              'ActionEnd', 'Beat')])
def test_header_of_every_timestamped_message_is_checked(msg_type):
    for t, reason in ((NOW + 1e5, 'time_in_future'),
                      (NOW - 1e5, 'time_too_old'),
                      (math.nan, 'time_not_finite'),
                      (2.0 ** 33, 'time_unrepresentable')):
        e = rejected(msg_type, header=hdr(t))
        assert (e.reason, e.field) == (reason, 'header.stamp'), t
    assert rejected(msg_type, header={'seq': 1}).reason == 'malformed'
    assert rejected(msg_type, header=hdr(NOW, 'f' * 5000)).reason == \
        'text_too_long'


def test_time_window_around_the_receivers_now():
    lim = Limits(past=10.0, future=2.0)
    ctx = Context(now=NOW, limits=lim)
    v.time_near(NOW - 10.0, 't', ctx)
    v.time_near(NOW + 2.0, 't', ctx)
    for t, reason in ((NOW - 10.1, 'time_too_old'),
                      (NOW + 2.1, 'time_in_future')):
        with pytest.raises(Rejected) as e:
            v.time_near(t, 't', ctx)
        assert e.value.reason == reason
    v.time_near(NOW + 5.0, 't', ctx, ahead=3.0)
    v.time_near(NOW - 1e6, 't', Context())        # now unknown


def test_capture_data_near_the_end_of_ros_time_is_refused():
    # The case: CR_T=4294967290 cut both DPMs off for good.
    assert rejected('hri_sync/CaptureData', header=hdr(4294967290.0),
                    ctx=Context()).reason == 'time_unrepresentable'
    assert rejected('hri_sync/CaptureData',
                    header=hdr(4294967290.0)).reason == 'time_in_future'


@pytest.mark.parametrize('change,reason', [
    (dict(dur=math.nan), 'not_finite'), (dict(dur=-1.0), 'out_of_range'),
    (dict(dur=0.0), 'out_of_range'), (dict(dur=1e6), 'out_of_range'),
    (dict(str_aft=-0.1), 'out_of_range'), (dict(str_aft=3e6), 'out_of_range'),
    (dict(str_aft=math.inf), 'not_finite'), (dict(clients=[]), 'list_empty'),
    (dict(clients=['left', 'left']), 'list_duplicate'),
    (dict(clients=['x' * 100]), 'name_too_long'),
    (dict(clients=['a b']), 'name_invalid'),
    (dict(clients=['c%d' % i for i in range(65)]), 'list_too_long'),
    (dict(round=0), 'round_invalid'), (dict(round=7), 'round_future'),
    (dict(round=3), 'round_old')])
def test_capture_data_rejections(change, reason):
    assert rejected('hri_sync/CaptureData', **change).reason == reason


def test_round_window_is_configurable():
    ctx = Context(round=5, limits=Limits(rounds_behind=0, rounds_ahead=0))
    v.round_number(5, ctx)
    for r, reason in ((4, 'round_old'), (6, 'round_future')):
        with pytest.raises(Rejected) as e:
            v.round_number(r, ctx)
        assert e.value.reason == reason
    v.round_number(10 ** 6, Context())          # no round in progress


@pytest.mark.parametrize('change,reason', [
    (dict(offset=math.nan), 'not_finite'),
    (dict(uncertainty=-0.001), 'out_of_range'),
    (dict(uncertainty=math.nan), 'not_finite'),
    (dict(drift=0.5), 'out_of_range'),
    (dict(sync_received=NOW + 1e6), 'time_in_future'),
    (dict(sync_received=NOW), 'out_of_order'),
    (dict(header=hdr(0.0)), 'time_not_positive'),
    (dict(client_id=''), 'name_empty'),
    (dict(reason='x' * 5000), 'text_too_long')])
def test_sync_ack_rejections(change, reason):
    # sync_received 1e6 s ahead made STR_AFT auto 3,000,000 s; a NaN
    # offset was accepted and the real ACK dropped as a duplicate.
    assert rejected('hri_sync/SyncAck', **change).reason == reason


def test_nack_without_a_clock_passes():
    v.check('hri_sync/SyncAck', dict(
        good('hri_sync/SyncAck'), ok=False, reason='time server silent',
        offset=math.nan, uncertainty=math.nan, sync_received=0.0,
        header=hdr(0.0)), CTX)


def test_sync_ack_latency_against_the_sync_time_stamp():
    fields = good('hri_sync/SyncAck')
    v.sync_ack(**fields, ctx=CTX, sent=NOW - 0.003)
    with pytest.raises(Rejected) as e:
        v.sync_ack(**fields, ctx=CTX, sent=NOW - 100.0)
    assert e.value.reason == 'latency_out_of_range'


def test_sync_ack_latency_from_the_context():
    # An ACK claiming it received sync_time 1e6 s ahead would inflate
    # STR_AFT auto; the CM's context carries the sync_time stamp.
    fields = dict(good('hri_sync/SyncAck'), sync_received=NOW + 1e6,
                  header=hdr(NOW + 1e6 + 0.001))
    ctx = dataclasses.replace(CTX, sync_sent=NOW - 0.003,
                              limits=Limits(future=2e6))
    with pytest.raises(Rejected) as e:
        v.check('hri_sync/SyncAck', fields, ctx)
    assert e.value.reason == 'latency_out_of_range'
    v.check('hri_sync/SyncAck', good('hri_sync/SyncAck'),
            dataclasses.replace(CTX, sync_sent=NOW - 0.003))


def test_client_must_match_the_context():
    ctx = Context(now=NOW, round=5, client='right')
    assert rejected('hri_sync/SyncAck', ctx=ctx).reason == 'wrong_client'


@pytest.mark.parametrize('change,reason', [
    (dict(end=NOW - 10.0), 'out_of_range'),
    (dict(start=NOW + 1e5, end=NOW + 1e5 + 1), 'time_in_future'),
    (dict(start=math.nan), 'time_not_finite'),
    (dict(end=2.0 ** 33), 'time_unrepresentable')])
def test_capture_command_rejections(change, reason):
    assert rejected('hri_sync/CaptureCommand', **change).reason == reason


@pytest.mark.parametrize('change,reason', [
    (dict(offset=math.nan), 'not_finite'),
    (dict(offset=1e9), 'out_of_range'),
    (dict(uncertainty=math.inf), 'not_finite'),
    (dict(local_ref=NOW + 1e6), 'time_in_future'),
    (dict(local_ref=-5.0), 'time_not_positive'),
    (dict(samples=0), 'out_of_range'),
    (dict(round_trip=-0.001), 'out_of_range'),
    (dict(round_trip=math.inf), 'not_finite')])
def test_clock_state_rejections(change, reason):
    assert rejected('hri_sync/ClockState', **change).reason == reason


def test_clock_state_must_map_now_to_a_valid_time():
    # Offset within (wide) limits, yet global now would be before 0, or
    # beyond the last ROS time.
    ctx = Context(local_now=NOW, limits=Limits(max_offset=1e10))
    for offset, reason in ((-NOW - 10.0, 'time_not_positive'),
                           (2.0 ** 32, 'time_unrepresentable')):
        assert rejected('hri_sync/ClockState', ctx=ctx, offset=offset,
                        local_ref=NOW - 1.0).reason == reason


def test_clock_state_failed_burst_has_no_round_trip():
    v.check('hri_sync/ClockState', dict(good('hri_sync/ClockState'),
                                        round_trip=math.nan), CTX)


def test_clock_state_not_ok_is_not_checked_further():
    v.check('hri_sync/ClockState', dict(
        good('hri_sync/ClockState'), ok=False, reason='no answer',
        offset=0.0, uncertainty=1e9, samples=0, local_ref=0.0), CTX)


@pytest.mark.parametrize('change,reason', [
    (dict(header={'stamp': NOW + 1000.0}), 'time_in_future'),
    (dict(header={'stamp': math.nan}), 'time_not_finite'),
    (dict(client_id='right'), 'wrong_client'),
    (dict(samples=-1), 'out_of_range'),
    (dict(sample_age=-0.5), 'out_of_range'),
    (dict(sample_age=math.inf), 'not_finite'),
    (dict(rate=math.inf), 'not_finite'),
    (dict(sample_age=math.nan), 'inconsistent'),
    (dict(input='x' * 5000), 'text_too_long')])
def test_dpm_state_rejections(change, reason):
    ctx = dataclasses.replace(CTX, client='left')
    assert rejected('hri_sync/DpmState', ctx=ctx, **change).reason == reason


def test_dpm_state_before_any_sample():
    v.check('hri_sync/DpmState', dict(
        good('hri_sync/DpmState'), samples=0, sample_age=math.nan,
        rate=math.nan), CTX)


@pytest.mark.parametrize('change,reason', [
    (dict(status='great'), 'unknown_value'),
    (dict(value=math.nan), 'not_finite'),
    (dict(value=math.inf), 'not_finite'),
    (dict(coverage=1.5), 'out_of_range'),
    (dict(coverage=math.nan), 'not_finite'),
    (dict(frames=0), 'inconsistent'),
    (dict(frames=-1), 'out_of_range'),
    (dict(first_frame_offset=math.inf), 'not_finite'),
    (dict(capture_end=NOW - 100.0), 'out_of_range'),
    (dict(capture_start=NOW - 1e5, capture_end=NOW - 1e5 + 60),
     'time_too_old'),
    (dict(diagnostics=[{'key': 'k', 'value': 'v' * 5000}]),
     'text_too_long'),
    (dict(diagnostics=[('k', 'v')] * 65), 'list_too_long')])
def test_client_result_rejections(change, reason):
    assert rejected('hri_sync/ClientResult', **change).reason == reason


def test_unusable_results_may_have_no_value():
    for status in ('no_data', 'late', 'error'):
        v.check('hri_sync/ClientResult', dict(
            good('hri_sync/ClientResult'), status=status, frames=0,
            value=math.nan, first_frame_offset=math.nan,
            wake_lateness=math.nan, coverage=0.0), CTX)


@pytest.mark.parametrize('change,reason', [
    (dict(outcome='draw'), 'unknown_value'),
    (dict(winner=3), 'out_of_range'), (dict(winner=0), 'inconsistent'),
    (dict(outcome='tie'), 'inconsistent'),
    (dict(scores=[1.0]), 'wrong_length'),
    (dict(scores=[1.0, math.inf]), 'not_finite'),
    (dict(header=hdr(math.nan)), 'time_not_finite')])
def test_decision_rejections(change, reason):
    assert rejected('hri_sync/Decision', **change).reason == reason


def test_decision_may_carry_nan_scores():
    v.check('hri_sync/Decision', dict(
        good('hri_sync/Decision'), outcome='no_winner', winner=0,
        scores=[math.nan, math.nan]), CTX)


def test_round_status_rejections():
    assert rejected('hri_sync/RoundStatus', state='x').reason == \
        'unknown_value'
    assert rejected('hri_sync/RoundStatus', missing=['ok', 'ok']).reason \
        == 'list_duplicate'


@pytest.mark.parametrize('change,reason', [
    (dict(positions=[(0, 0, 1)] * 14), 'wrong_length'),
    (dict(positions=[]), 'wrong_length'),
    (dict(confidence=[1.0] * 16), 'wrong_length'),
    (dict(confidence=[math.nan] * 15), 'not_finite'),
    (dict(confidence=[2.0] * 15), 'out_of_range'),
    (dict(positions=[(math.inf, 0, 1)] * 15), 'not_finite'),
    (dict(positions=[(1e4, 0, 1)] * 15), 'out_of_range'),
    (dict(positions=[(0, 1)] * 15), 'malformed'),
    (dict(device_stamp=0.0), 'time_not_positive'),
    (dict(device_stamp=2.0 ** 32 + 5), 'time_unrepresentable'),
    (dict(header={'stamp': NOW + 1e4}), 'time_in_future'),
    (dict(header={}), 'malformed'),
    (dict(client_id='a/b'), 'name_invalid'),
    (dict(frame_index=-1), 'out_of_range'),
    (dict(frames_skipped=1.5), 'not_a_number'),
    (dict(sources=['left', 'left']), 'list_duplicate'),
    (dict(sources=['left/']), 'name_empty'),
    (dict(sources=['left', 3]), 'not_a_string')])
def test_skeleton_rejections(change, reason):
    assert rejected('hri_sync/Skeleton', **change).reason == reason


def test_skeleton_nan_joints_are_a_setting():
    nan_joint = [(math.nan, math.nan, math.nan)] + [(0, 0, 1)] * 14
    v.check('hri_sync/Skeleton', dict(good('hri_sync/Skeleton'),
                                      positions=nan_joint), CTX)
    strict = Context(now=NOW, limits=Limits(nan_joints=False))
    assert rejected('hri_sync/Skeleton', ctx=strict,
                    positions=nan_joint).reason == 'not_finite'


def test_sample_value_nan_passes_inf_does_not():
    v.check('hri_sync/Sample', dict(good('hri_sync/Sample'),
                                    value=math.nan), CTX)
    assert rejected('hri_sync/Sample', value=-math.inf).reason == \
        'not_finite'


def test_robot_messages():
    assert rejected('hri_sync/Led', value=9).reason == 'unknown_value'
    assert rejected('hri_sync/Sound', value=-1).reason == 'out_of_range'
    assert rejected('geometry_msgs/Twist',
                    linear=(math.nan, 0, 0)).reason == 'not_finite'
    bad_q = {'pose': {'position': (0, 0, 0),
                      'orientation': (0, 0, 0, 0.5)},
             'covariance': [0.0] * 36}
    assert rejected('nav_msgs/Odometry', pose=bad_q).reason == 'malformed'
    assert rejected('hri_sync/Beat', bpm=0.0).reason == 'out_of_range'
    assert rejected('hri_sync/ActionStart', action='').reason == \
        'name_empty'
    assert rejected('hri_sync/ActionStart', kind='sing').reason == \
        'unknown_value'
    assert rejected('hri_sync/ActionStart', status='late').reason == \
        'no_reason'
    assert rejected('hri_sync/ActionStart', tolerance=-1.0).reason == \
        'out_of_range'
    v.check('hri_sync/ActionStart', dict(
        good('hri_sync/ActionStart'), action='light_on', kind='publish',
        event='decision', status='failed', reason='no such topic type',
        tolerance=0.005, local_time=NOW), CTX)



def test_action_end_rejections():
    assert rejected('hri_sync/ActionEnd', status='done').reason == \
        'unknown_value'
    assert rejected('hri_sync/ActionEnd', kind='').reason == \
        'unknown_value'
    for status in ('failed', 'timeout'):
        assert rejected('hri_sync/ActionEnd', status=status).reason == \
            'no_reason'
    assert rejected('hri_sync/ActionEnd', duration=-0.1).reason == \
        'out_of_range'
    assert rejected('hri_sync/ActionEnd', duration=math.inf).reason == \
        'not_finite'
    assert rejected('hri_sync/ActionEnd', started=NOW - 1e5).reason == \
        'time_too_old'
    assert rejected('hri_sync/ActionEnd', client_id='').reason == \
        'name_empty'
    v.check('hri_sync/ActionEnd', dict(
        good('hri_sync/ActionEnd'), kind='command', status='timeout',
        reason='no end 30.00 s after its start: killed', duration=30.0,
        timeout=30.0), CTX)


def test_stamp_order_rejects_a_repeated_stamp_only():
    order = v.StampOrder()
    order.check('left', 10.0)
    order.check('right', 10.0)
    order.check('left', 9.0)        # went back: a restart, let through
    with pytest.raises(Rejected) as e:
        order.check('left', 9.0)
    assert e.value.reason == 'stamp_repeated'


def test_unknown_type_has_no_validator():
    with pytest.raises(KeyError):
        v.check('std_msgs/String', {'data': 'x'}, CTX)


def test_noise_floors_unknown_or_invalid():
    """A client's NaN or negative noise floor does not reject its result
    (the DM takes it as unknown and counts it); the DM's own list is NaN
    or >= 0, one per client or none."""
    for floor in (math.nan, -1.0, math.inf):
        v.check('hri_sync/ClientResult',
                dict(good('hri_sync/ClientResult'), noise_floor=floor), CTX)
    v.check('hri_sync/Decision',
            dict(good('hri_sync/Decision'), noise_floors=[]), CTX)
    v.check('hri_sync/Decision',
            dict(good('hri_sync/Decision'), noise_floors=[math.nan, 0.0]),
            CTX)
    for bad in ([0.1], [-0.1, 0.1]):
        with pytest.raises(v.Rejected):
            v.check('hri_sync/Decision',
                    dict(good('hri_sync/Decision'), noise_floors=bad), CTX)
    for source in ('', 'uncalibrated', 'estimate'):
        v.check('hri_sync/ClientResult',
                dict(good('hri_sync/ClientResult'), noise_source=source), CTX)
    with pytest.raises(v.Rejected, match='noise_source'):
        v.check('hri_sync/ClientResult',
                dict(good('hri_sync/ClientResult'), noise_source='guess'), CTX)


def test_calibration_topics_carry_round_zero_only():
    """The calibration window is round 0 on the calibration/ topics, and
    round 0 nowhere else."""
    cal = v.Context(now=NOW, calibration=True)
    for kind in ('hri_sync/CaptureData', 'hri_sync/ClientResult',
                 'hri_sync/Decision'):
        fields = dict(good(kind), round=0)
        if kind == 'hri_sync/Decision':
            fields.update(outcome='no_winner', winner=0)
        v.check(kind, fields, cal)
        with pytest.raises(v.Rejected, match='rounds count from 1'):
            v.check(kind, fields, CTX)
        with pytest.raises(v.Rejected, match='calibration window is round'):
            v.check(kind, dict(fields, round=1), cal)
