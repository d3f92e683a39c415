#!/usr/bin/python3
"""Publishes /sync_time at ~rate Hz with round ~round, for the inbox
rostest; with ~bad_every N, every Nth message has round 0 (invalid)."""
import time

import rospy
from std_msgs.msg import Header

from hri_sync.msg import SyncTime
from hri_sync.ros.node import init_checker


def main():
    init_checker('inbox_talker')
    rate = rospy.Rate(rospy.get_param('~rate', 20.0))
    round_id = rospy.get_param('~round')
    bad_every = rospy.get_param('~bad_every', 0)
    pub = rospy.Publisher('/sync_time', SyncTime, queue_size=10)
    n = 0
    while not rospy.is_shutdown():
        n += 1
        bad = bad_every and n % bad_every == 0
        pub.publish(SyncTime(
            header=Header(stamp=rospy.Time.from_sec(time.time())),
            round=0 if bad else round_id))
        rate.sleep()


if __name__ == '__main__':
    main()
