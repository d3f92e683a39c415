#!/usr/bin/python3
"""Relays a topic with a fixed delay: network latency injected in the
application (this kernel has no tc netem).  Params: ~input, ~output,
~type (e.g. hri_sync/SyncTime), ~delay (s)."""
import threading
import time

import roslib.message
import rospy

from hri_sync.ros.node import init_checker


def main():
    init_checker('delay_relay')
    delay = rospy.get_param('~delay')
    msg_class = roslib.message.get_message_class(rospy.get_param('~type'))
    pub = rospy.Publisher(rospy.get_param('~output'), msg_class,
                          queue_size=10)

    def forward(msg, due):
        time.sleep(max(0.0, due - time.time()))
        pub.publish(msg)

    def on_msg(msg):
        threading.Thread(target=forward, args=(msg, time.time() + delay),
                         daemon=True).start()

    rospy.Subscriber(rospy.get_param('~input'), msg_class, on_msg)
    rospy.spin()


if __name__ == '__main__':
    main()
