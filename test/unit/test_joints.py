"""hri_sync.dance_off.joints and msg/Skeleton.msg: the same 15 joints."""

import os
import re

from hri_sync.dance_off.joints import INDEX, JOINTS, NUM_JOINTS

MSG = os.path.join(os.path.dirname(__file__), '..', '..', 'msg',
                   'Skeleton.msg')


def test_constants_match_joint_order():
    with open(MSG) as f:
        text = f.read()
    constants = dict((name, int(value)) for name, value in re.findall(
        r'^uint8 ([A-Z_]+)=(\d+)\s*$', text, re.M))
    assert constants.pop('NUM_JOINTS') == NUM_JOINTS == 15
    assert constants == {name.upper(): i for i, name in enumerate(JOINTS)}
    for field in ('geometry_msgs/Point[15] positions',
                  'geometry_msgs/Quaternion[15] orientations',
                  'float32[15] confidence'):
        assert field in text
    assert all(INDEX[name] == i for i, name in enumerate(JOINTS))
