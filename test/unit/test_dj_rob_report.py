"""hri_sync.robot.report: dj_rob_monitor's text for one round."""
import math

from hri_sync.robot.report import Started, round_report

BEARINGS = [30.0, -30.0]


def odom(start=10.0, end=22.0, final_deg=29.98):
    """Samples at 50 Hz: a dance swinging +-30 deg and 0.07 m forward in
    the window 11..16, then turned to ``final_deg``."""
    out = []
    t = start
    while t <= end:
        if t < 16.0:
            yaw = math.radians(30.0) * math.sin(t)
            x = 0.07 * abs(math.sin(t)) if t >= 11.0 else 0.0
        else:
            yaw, x = math.radians(final_deg), 0.0
        out.append((t, x, 0.0, yaw))
        t += 0.02
    return out


def test_winner_round():
    lines = round_report(
        1, 'winner', 1, 'left scored highest', BEARINGS, now=22.0,
        window=(11.0, 5.0),
        starts={'music': Started(0.00012, 11.0001),
                'dance': Started(0.00011, 11.00008)},
        actions=['music', 'dance'], odom=odom())
    assert lines[0] == 'DJ Rob, round 1'
    assert lines[1] == ('  music started +0.12 ms from the scheduled start '
                        'by its clock (+0.10 ms by the host clock)')
    assert lines[2].startswith('  dance started +0.11 ms')
    assert lines[3] == ('  dance: heading between -30.0 and +30.0 deg, up '
                        'to 0.07 m from the start (odometry)')
    assert lines[4] == '  decision: winner participant 1 (left scored highest)'
    assert lines[5] == ('  gesture done: robot at (0.000, 0.000) m, heading '
                        '+30.0 deg; participant 1 at +30.0 deg: off by '
                        '0.0 deg')
    assert len(lines) == 6


def test_no_winner_missing_start_still_moving():
    lines = round_report(
        2, 'no_winner', 0, 'nobody moved', BEARINGS, now=22.0,
        window=(11.0, 5.0), starts={}, actions=['dance'],
        odom=odom(final_deg=-170.0 - 360.0), rested=False)
    assert lines[1] == '  dance no start reported'
    assert lines[3] == '  decision: no_winner (nobody moved)'
    assert lines[4] == ('  no gesture; robot at (0.000, 0.000) m, heading '
                        '-170.0 deg')


def test_off_by_wraps_and_still_moving_is_said():
    lines = round_report(3, 'winner', 2, '', BEARINGS, now=22.0,
                         odom=odom(final_deg=170.0), rested=False)
    assert lines[-1] == ('  gesture done (still moving): robot at (0.000, '
                         '0.000) m, heading +170.0 deg; participant 2 at '
                         '-30.0 deg: off by 160.0 deg')


def test_without_window_or_fresh_odometry():
    lines = round_report(4, 'winner', 1, 'r', BEARINGS, now=30.0,
                         odom=odom())
    assert lines == ['DJ Rob, round 4', '  decision: winner participant 1 '
                     '(r)', '  no /odom: the final heading is unknown']
    assert round_report(4, 'winner', 1, 'r', BEARINGS, now=30.0)[-1] == \
        '  no /odom: the final heading is unknown'


def test_winner_out_of_range_gets_no_gesture_line():
    lines = round_report(5, 'winner', 9, 'r', BEARINGS, now=22.0,
                         odom=odom())
    assert lines[-1].startswith('  no gesture; robot at')
