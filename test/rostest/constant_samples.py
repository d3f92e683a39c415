"""The participants' constant samples the round checkers publish (a
module beside them: a checker's folder is first on its sys.path)."""
import threading

import rospy

from hri_sync.msg import Sample


def publish_constant_samples(values, rate=50.0):
    """In a daemon thread, publish ``values[c]`` on ``~<c>_samples`` for
    each client ``c`` at ``rate`` Hz, stamped now, until shutdown."""
    def run():
        pubs = {c: rospy.Publisher('~%s_samples' % c, Sample, queue_size=10)
                for c in values}
        index = 0
        sleeper = rospy.Rate(rate)
        while not rospy.is_shutdown():
            for c, pub in pubs.items():
                msg = Sample(index=index, value=values[c])
                msg.header.stamp = rospy.Time.now()
                pub.publish(msg)
            index += 1
            sleeper.sleep()
    threading.Thread(target=run, daemon=True).start()
