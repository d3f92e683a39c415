"""rospy's XML-RPC server stops at shutdown (hri_sync.ros.rpc_server),
where rosgraph alone leaves its thread polling a closed socket."""
import os
import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent('''
    import sys, threading, time
    from rosgraph.xmlrpc import XmlRpcNode
    from hri_sync.ros.rpc_server import stop_serving_at_shutdown
    if sys.argv[1] == 'fixed':
        stop_serving_at_shutdown()
    returned = threading.Event()

    class Node(XmlRpcNode):
        def run(self):
            super().run()
            returned.set()

    node = Node()
    node.start()
    deadline = time.monotonic() + 30.0
    while node.uri is None and time.monotonic() < deadline:
        time.sleep(0.01)
    assert node.uri, 'the server never started'
    node.shutdown('test')
    print('returned' if returned.wait(float(sys.argv[2])) else 'still serving')
''')


def serve_and_stop(mode, wait):
    """'returned' or 'still serving' ``wait`` s after the shutdown."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    out = subprocess.run([sys.executable, '-c', SCRIPT, mode, str(wait)],
                         env=env, capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


def test_the_server_thread_returns_at_shutdown():
    assert serve_and_stop('fixed', 30.0) == 'returned'


def test_without_the_fix_rosgraph_keeps_serving():
    """The bug the module works around (ros/ros_comm#2238): if a rosgraph
    release fixes it, this fails and the module can go."""
    assert serve_and_stop('plain', 1.0) == 'still serving'
