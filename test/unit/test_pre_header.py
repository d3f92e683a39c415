"""Recordings made before the timestamped messages got a std_msgs/Header
(issue 13) stay readable.

test/bags/session_robot.bag was recorded with those definitions (their
global stamp in ``stamp``, ``cr_t``, ``actual``); a copy in today's shape
(each stamp moved into header.stamp by bag_edit.to_header_shape) must
give the offline tools the same figures.
"""
import math
import os

import pytest

pytest.importorskip('rosbags', reason='rosbags is installed by make venv')

from rosbags.rosbag1 import Reader  # noqa: E402

import bag_edit  # noqa: E402
from hri_sync.tools import analysis, bag  # noqa: E402
from hri_sync.tools.session import (build_session, secs,  # noqa: E402
                                    stamp_of)

ROOT = os.path.join(os.path.dirname(__file__), '..', '..')
OLD = os.path.join(ROOT, 'test', 'bags', 'session_robot.bag')
MSG_DIR = os.path.join(ROOT, 'msg')


@pytest.fixture(scope='module')
def new(tmp_path_factory):
    """session_robot.bag in today's message shape."""
    path = str(tmp_path_factory.mktemp('bags') / 'session_robot_new.bag')
    assert bag_edit.to_header_shape(OLD, path, MSG_DIR) > 0
    return path


def test_the_old_bag_is_read_without_a_flag():
    with Reader(OLD) as r:
        digests = {c.msgtype.replace('/msg/', '/'): c.digest
                   for c in r.connections}
    ours = bag.current_md5sums()
    for kind, md5 in bag.PRE_HEADER.items():
        assert digests[kind] == md5 != ours[kind], kind
    c = bag.read_bag(OLD)
    assert not c.old_types
    assert sorted(c.pre_header) == sorted(bag.PRE_HEADER)


def test_the_new_shape_is_todays(new):
    c = bag.read_bag(new)
    assert not c.old_types and not c.pre_header
    assert c.messages['/capture_data'][0].msg.header.frame_id == ''


def test_stamp_of_reads_both_shapes(new):
    old_c, new_c = bag.read_bag(OLD), bag.read_bag(new)
    checked = set()
    for topic, kind in old_c.topics.items():
        if kind not in bag.PRE_HEADER:
            continue
        pairs = list(zip(old_c.messages[topic], new_c.messages[topic]))
        assert pairs and len(pairs) == len(new_c.messages[topic])
        field = {'hri_sync/CaptureData': 'cr_t',
                 'hri_sync/ActionStart': 'actual',
                 'hri_sync/CaptureCommand': None,
                 'hri_sync/ClientResult': None}.get(kind, 'stamp')
        for o, n in pairs:
            if field is None:       # no stamp before the header
                assert math.isnan(stamp_of(o.msg)), topic
                assert stamp_of(n.msg) == 0.0
                continue
            assert stamp_of(o.msg) == secs(getattr(o.msg, field)) == \
                stamp_of(n.msg) == secs(n.msg.header.stamp), topic
        checked.add(kind)
    assert checked == set(bag.PRE_HEADER)


def test_the_report_is_the_same_from_both_shapes(new):
    def figures(path):
        s = analysis.clean(analysis.summarize(build_session(
            bag.read_bag(path))))
        del s['bag'], s['pre_header_types']
        return s
    old = figures(OLD)
    assert [r['decision']['outcome'] for r in old['rounds']] == \
        ['winner', 'winner']
    assert all(r['cr_t'] and r['decision']['stamp'] for r in old['rounds'])
    assert figures(new) == old
