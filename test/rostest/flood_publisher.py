#!/usr/bin/python3
"""Floods /capture_data from a foreign node (issue 11's fault matrix).

Publishes ``~count`` CaptureData messages at ``~rate`` Hz after
``~delay`` s: plausible orders (CR_T now, STR_AFT 0.5 s, DUR 3 s, both
clients) for rounds 1..``~rounds``, seeded.  Each must be rejected as
from the wrong sender.  Sets ``~sent`` when done.
"""
import random
import time

import rospy
from std_msgs.msg import Header

from hri_sync.msg import CaptureData
from hri_sync.ros.node import init_checker


def main():
    init_checker('flooder')
    rate = rospy.get_param('~rate', 200.0)
    count = rospy.get_param('~count', 4000)
    rounds = rospy.get_param('~rounds', 3)
    rng = random.Random(rospy.get_param('~seed', 11))
    pub = rospy.Publisher('/capture_data', CaptureData, queue_size=1000)
    time.sleep(rospy.get_param('~delay', 2.0))
    sent = 0
    due = time.monotonic()
    while sent < count and not rospy.is_shutdown():
        pub.publish(CaptureData(
            header=Header(stamp=rospy.Time.from_sec(time.time())),
            round=rng.randint(1, rounds), str_aft=0.5, dur=3.0,
            clients=['left', 'right']))
        sent += 1
        due += 1.0 / rate
        time.sleep(max(0.0, due - time.monotonic()))
    rospy.set_param('~sent', sent)
    rospy.loginfo('flooder: %d CaptureData sent on /capture_data', sent)
    rospy.spin()


if __name__ == '__main__':
    main()
