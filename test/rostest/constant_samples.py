"""The participants' constant samples the round checkers publish (a
module beside them: a checker's folder is first on its sys.path)."""
import threading

import rospy

from hri_sync.msg import Sample
from hri_sync.ros.timers import wait_for


def publish_constant_samples(values, rate=50.0, observers=(),
                             timeout=30.0):
    """In a daemon thread, publish ``values[c]`` on ``~<c>_samples`` for
    each client ``c`` at ``rate`` Hz, stamped now, until shutdown.

    The CM starts no round before a participant's sensor gave a sample,
    so waiting first (at most ``timeout`` s) until each subscriber of
    ``observers`` is connected to a publisher means the checker sees the
    round's capture_data, however late its connections come on a busy
    machine.  A subscriber still unconnected is logged, not waited for."""
    wait_for(lambda: all(sub.get_num_connections() for sub in observers),
             timeout, 0.05)
    for sub in observers:
        if sub.get_num_connections() < 1:
            rospy.logwarn('%s has no publisher after %.0f s: feeding the '
                          'samples anyway', sub.resolved_name, timeout)

    def run():
        pubs = {c: rospy.Publisher('~%s_samples' % c, Sample, queue_size=10)
                for c in values}
        index = 0
        sleeper = rospy.Rate(rate)
        while not rospy.is_shutdown():
            try:
                for c, pub in pubs.items():
                    msg = Sample(index=index, value=values[c])
                    msg.header.stamp = rospy.Time.now()
                    pub.publish(msg)
                sleeper.sleep()
            except rospy.ROSException:
                # rospy closes its topics before is_shutdown() turns true
                if not rospy.core.is_shutdown_requested():
                    raise
                return          # closed at shutdown
            index += 1
    threading.Thread(target=run, daemon=True).start()
