"""rospy's XML-RPC server, stopped instead of left spinning at shutdown.

rosgraph's ``XmlRpcNode.shutdown`` closes the server's socket but never
asks ``serve_forever`` to return, so the server thread polls the closed
socket in a busy loop until the process exits (ros/ros_comm#2238).  Every
rospy node spent up to 0.5 s of CPU so at each shutdown, while its other
threads joined (bench/node_cost.py, idle machine: 0.785 against 0.582 CPU s
for a node that only inits).  ``stop_serving_at_shutdown`` makes the
shutdown ask the server to return first (socketserver's own ``shutdown``,
in a thread: it waits for the loop, which returns at the next poll, when
the socket is closed).
"""
import threading

from rosgraph.xmlrpc import XmlRpcNode

_close = XmlRpcNode.shutdown


def _shutdown(node, reason):
    server = node.server
    if server is not None:
        threading.Thread(target=server.shutdown, daemon=True,
                         name='xmlrpc_stop').start()
    _close(node, reason)


def stop_serving_at_shutdown():
    """From now on, rospy's XML-RPC servers in this process stop at
    shutdown (call before ``rospy.init_node``; calling again is harmless)."""
    XmlRpcNode.shutdown = _shutdown
