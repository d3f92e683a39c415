"""hri_sync.ros.lifeline: children that die with their parent, even when
the parent is killed with SIGKILL (a real kernel test, no ROS)."""
import os
import signal
import subprocess
import sys
import time

import hri_sync

SRC = os.path.dirname(os.path.dirname(os.path.abspath(hri_sync.__file__)))
LIFELINE = os.path.join(SRC, '..', 'scripts', 'lifeline')
ENV = dict(os.environ, PYTHONPATH=SRC)

# A parent that starts a long sleep as its child, prints the child's pid
# and waits; ``how`` sets the child's lifeline.
PARENT = '''
import os, subprocess, sys, time
from hri_sync.ros.lifeline import tie_to
how = sys.argv[1]
if how == 'preexec':
    child = subprocess.Popen(['sleep', '60'], preexec_fn=tie_to(os.getpid()))
elif how == 'script':
    child = subprocess.Popen([sys.executable, sys.argv[2], 'sleep', '60'])
else:
    child = subprocess.Popen(['sleep', '60'])
print(child.pid, flush=True)
time.sleep(60)
'''


def alive(pid):
    """True unless ``pid`` is gone or a zombie."""
    try:
        with open('/proc/%d/stat' % pid) as f:
            stat = f.read()
    except OSError:
        return False
    return stat[stat.rfind(')') + 2] not in 'ZX'


def cmdline(pid):
    """The arguments of ``pid`` ([] if it is gone)."""
    try:
        with open('/proc/%d/cmdline' % pid) as f:
            return f.read().split('\0')[:-1]
    except OSError:
        return []


def orphan_after_sigkill(how, deadline=20.0):
    """Kill the parent with SIGKILL; True if its child outlived it by
    ``deadline`` s (for the kernel, far above the microseconds it takes)."""
    parent = subprocess.Popen(
        [sys.executable, '-c', PARENT, how, LIFELINE], env=ENV,
        stdout=subprocess.PIPE, text=True)
    child = int(parent.stdout.readline())
    # The lifeline script sets the lifeline, then execs sleep: wait for
    # the exec (a fixed pause loses the race on a loaded machine).
    start = time.monotonic()
    while cmdline(child) != ['sleep', '60'] and \
            time.monotonic() - start < deadline:
        time.sleep(0.02)
    assert cmdline(child) == ['sleep', '60']
    assert alive(child)
    parent.kill()
    parent.wait()
    deadline += time.monotonic()
    while alive(child) and time.monotonic() < deadline:
        time.sleep(0.05)
    survived = alive(child)
    if survived:
        os.kill(child, signal.SIGKILL)
    return survived


def test_without_a_lifeline_the_child_is_orphaned():
    assert orphan_after_sigkill('none', deadline=2.0)


def test_a_tied_child_dies_with_its_parent():
    assert not orphan_after_sigkill('preexec')


def test_the_lifeline_script_ties_any_command():
    assert not orphan_after_sigkill('script')


def test_a_parent_already_gone_signals_at_once():
    code = subprocess.run(
        [sys.executable, '-c', 'import time\n'
         'from hri_sync.ros.lifeline import die_with_parent\n'
         'die_with_parent(parent=1)\n'
         'time.sleep(10)\n'], env=ENV, timeout=30).returncode
    assert code == -signal.SIGTERM


def test_node_name_is_resolved_in_roslaunch_namespace():
    from hri_sync.ros.lifeline import node_name
    args = ['rosbag', 'record', '-O', 'x.bag', '__name:=recorder',
            '__log:=/tmp/r.log']
    assert node_name(args, None) == '/recorder'
    assert node_name(args, '/lab1/') == '/lab1/recorder'
    assert node_name(['rosbag', 'record'], '/lab1') is None


def test_next_output_never_overwrites_the_closed_bag():
    from hri_sync.ros.lifeline import next_output
    assert next_output(['rosbag', 'record', '-O', '/d/s.bag', '/a'], 2) == \
        ['rosbag', 'record', '-O', '/d/s.restart2.bag', '/a']
    assert next_output(['record', '--output-name=/d/s', '/a'], 1) == \
        ['record', '--output-name=/d/s.restart1.bag', '/a']
    # -o PREFIX: rosbag already stamps each new bag with its start time
    assert next_output(['record', '-o', '/d/s', '/a'], 1) == \
        ['record', '-o', '/d/s', '/a']


# A node's main thread holds a plain lock that a shutdown hook needs (as
# rospy's queued /rosout publisher holds its connection's lock while the
# node logs) when the lifeline's SIGTERM comes.
SIGTERM_IN_LOCK = '''
import os, signal, threading, time
import rospy
from hri_sync.ros.node import _shutdown_in_a_thread
signal.signal(signal.SIGTERM, _shutdown_in_a_thread)
lock = threading.Lock()
rospy.core.add_preshutdown_hook(lambda reason: lock.acquire())
with lock:
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(0.2)
deadline = time.monotonic() + 20
while not rospy.is_shutdown() and time.monotonic() < deadline:
    time.sleep(0.01)
print('shut down' if rospy.is_shutdown() else 'not shut down')
'''


def test_sigterm_inside_a_lock_still_shuts_the_node_down():
    out = subprocess.run([sys.executable, '-c', SIGTERM_IN_LOCK], env=ENV,
                         capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == 'shut down', out.stderr[-2000:]
