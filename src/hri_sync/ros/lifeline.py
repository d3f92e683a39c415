"""Lifelines: a process that dies with its parent (Linux).

roslaunch starts each node in a session of its own, so a roslaunch killed
with SIGKILL leaves every node running, re-parented to init.  A node that
calls ``die_with_parent()`` gets ``signum`` from the kernel when its
parent dies (PR_SET_PDEATHSIG), and shuts down as on Ctrl-C.
``tie_to(pid)`` does the same for a child, as a ``subprocess.Popen``
``preexec_fn``.  The setting survives exec, but not a change of user: a
program that drops privileges (chronyd as root) must be told to keep its
user.  The kernel signals the child when the *thread* that forked it
ends, so fork from a thread that lives as long as the process (roslaunch
and the nodes here fork from their main thread).

``scripts/lifeline CMD ...`` runs any command with a lifeline (a
launch-prefix for programs that are not ours: rosbag record, rostopic).
"""
import ctypes
import os
import signal

PR_SET_PDEATHSIG = 1


def _prctl_pdeathsig(signum):
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(PR_SET_PDEATHSIG, int(signum), 0, 0, 0) != 0:
        err = ctypes.get_errno()
        raise OSError(err, 'prctl(PR_SET_PDEATHSIG): %s' % os.strerror(err))


def die_with_parent(signum=signal.SIGTERM, parent=None):
    """Have the kernel send ``signum`` to this process when its parent
    dies.  ``parent``: the pid the parent must be (default: the parent
    now); if it already died, ``signum`` is sent at once."""
    parent = os.getppid() if parent is None else parent
    _prctl_pdeathsig(signum)
    if os.getppid() != parent:      # it died before the lifeline was set
        os.kill(os.getpid(), signum)


def tie_to(parent, signum=signal.SIGTERM):
    """A Popen ``preexec_fn``: the child gets ``signum`` when ``parent``
    (the pid calling Popen) dies."""
    return lambda: die_with_parent(signum, parent)


def node_name(args, namespace):
    """The resolved node name roslaunch gave a command (``__name:=``
    among ``args``, in ``namespace``, roslaunch's ROS_NAMESPACE); None
    without one."""
    names = [a.split(':=', 1)[1] for a in args if a.startswith('__name:=')]
    if not names:
        return None
    ns = '/' + (namespace or '').strip('/')
    return (ns.rstrip('/') + '/' + names[-1].lstrip('/'))


def next_output(args, restart):
    """``rosbag record`` args writing to a new bag after the ``restart``th
    master restart: ``-O PATH.bag`` (or ``--output-name``) becomes
    ``PATH.restartN.bag``, so the bag closed before is kept; ``-o``
    prefixes already get a new time-stamped name."""
    out = list(args)
    for i, a in enumerate(out):
        if a in ('-O', '--output-name') and i + 1 < len(out):
            out[i + 1] = _restart_path(out[i + 1], restart)
        elif a.startswith('--output-name='):
            out[i] = '--output-name=' + _restart_path(a.split('=', 1)[1],
                                                      restart)
    return out


def _restart_path(path, restart):
    stem = path[:-4] if path.endswith('.bag') else path
    return '%s.restart%d.bag' % (stem, restart)
