"""hri_sync.data_process.orders: a DPM takes a capture command only for a
round the CM ordered its client into, with the same window (local times
are numbers the test advances)."""
import random

import pytest

from hri_sync.data_process.orders import CommandGate, Command

T0 = 1000.0                 # local time of the CM's order
START, END = 1.7e9 + 0.25, 1.7e9 + 5.25   # global window of round 3
LAST = 2 ** 32 - 1          # the fuzzer's round


def ros_time(t):
    """``t`` as a ROS time carries it: whole nanoseconds."""
    return int(round(t * 1e9)) / 1e9


def test_the_cpms_command_after_the_cms_order_is_taken_at_once():
    g = CommandGate('left')
    assert g.order(3, START, END, ['left', 'right'], T0) == []
    assert g.command(3, ros_time(START), ros_time(END), T0 + 0.002) == [
        Command(3, ros_time(START), ros_time(END))]
    assert g.expire(T0 + 10.0) == [] and not g.counts


def test_a_command_before_the_order_waits_for_it():
    g = CommandGate('left', wait=2.0)
    assert g.command(3, START, END, T0) == []
    assert g.order(3, START, END, ['left'], T0 + 1.5) == [
        Command(3, START, END)]
    assert g.expire(T0 + 10.0) == [] and not g.counts


def test_a_forged_command_for_round_2_32_minus_1_in_a_clean_round():
    """The fuzzer's command under the CPM's caller id, between the CM's
    order of round 3 and the CPM's own: rejected after ``wait`` and
    counted; round 3 is taken."""
    g = CommandGate('left', wait=2.0)
    g.order(3, START, END, ['left', 'right'], T0)
    assert g.command(LAST, START - 0.1, START + 2.0, T0 + 0.001) == []
    assert g.command(3, START, END, T0 + 0.002) == [Command(3, START, END)]
    assert g.expire(T0 + 1.9) == []
    (r,) = g.expire(T0 + 2.1)
    assert (r.command.round, r.reason) == (LAST, 'unscheduled_round')
    assert 'no capture_data of the CM names left in round 4294967295' \
        in r.why
    assert g.counts == {'unscheduled_round': 1}
    assert g.expire(T0 + 5.0) == []


def test_an_order_that_does_not_name_the_client_confirms_nothing():
    g = CommandGate('left', wait=1.0)
    assert g.command(3, START, END, T0) == []
    assert g.order(3, START, END, ['right'], T0) == []
    assert [r.reason for r in g.expire(T0 + 1.5)] == ['unscheduled_round']


def test_a_command_for_an_ordered_round_with_another_window():
    g = CommandGate('left', wait=1.0)
    g.order(3, START, END, ['left'], T0)
    assert g.command(3, START + 1e-3, END, T0) == []
    (r,) = g.expire(T0 + 1.5)
    assert r.reason == 'unscheduled_window'
    assert 'the CM ordered round 3 for [1700000000.250000, ' in r.why
    assert g.counts == {'unscheduled_window': 1}


def test_an_order_is_forgotten_after_wait():
    g = CommandGate('left', wait=1.0)
    g.order(3, START, END, ['left'], T0)
    g.expire(T0 + 1.5)
    assert g.command(3, START, END, T0 + 1.6) == []
    assert [r.reason for r in g.expire(T0 + 3.0)] == ['unscheduled_round']


def test_a_flood_of_forged_commands_stays_bounded_and_counted():
    rng = random.Random(7)
    g = CommandGate('left', wait=1.0, limit=50)
    for k in range(200):
        g.command(rng.randrange(1, 2 ** 32), START, END, T0 + k * 1e-4)
    assert len(g.held) == 50 and g.counts['unscheduled_round'] == 150
    g.order(3, START, END, ['left'], T0 + 0.05)
    assert g.command(3, START, END, T0 + 0.05) == [Command(3, START, END)]
    assert len(g.expire(T0 + 2.0)) == 200
    assert g.counts == {'unscheduled_round': 200}


def test_wait_must_be_positive():
    with pytest.raises(ValueError, match='order wait'):
        CommandGate('left', wait=0.0)


def test_each_forged_message_is_counted():
    g = CommandGate('left', wait=1.0)
    for k in range(3):
        g.command(LAST, START, END, T0 + k * 0.1)
    assert len(g.expire(T0 + 2.0)) == 3
    assert g.counts == {'unscheduled_round': 3}
