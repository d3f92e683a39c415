"""The process tree: find, signal and reap a process's descendants.

Contract: no rospy.  What ``skewed_client`` (a client under libfaketime),
the benches and the test checkers share: /proc read into ``ProcInfo``, a
process's CPU seconds, its live descendants, this process made a child
subreaper (so orphans stay in its tree), and a process group stopped
SIGINT -> SIGTERM -> SIGKILL.
"""
import ctypes
import os
import signal
import subprocess
from dataclasses import dataclass

PR_SET_CHILD_SUBREAPER = 36
DEAD_STATES = ('Z', 'X')    # zombie, dead: in /proc but no longer running


# --------------------------------------------------------------- processes

@dataclass(frozen=True)
class ProcInfo:
    """One process as /proc/PID/stat shows it."""

    ppid: int
    pgid: int
    state: str      # R, S, D, Z, ...
    start: int      # start time, clock ticks after boot
    name: str = ''  # the command name (comm), e.g. 'chronyd'

    @property
    def live(self):
        """Running, not a zombie."""
        return self.state not in DEAD_STATES


def proc_table():
    """{pid: ProcInfo} of every process in /proc."""
    table = {}
    for name in os.listdir('/proc'):
        if not name.isdigit():
            continue
        try:
            with open('/proc/%s/stat' % name) as f:
                stat = f.read()
        except OSError:
            continue    # ended while we listed
        fields = stat[stat.rfind(')') + 2:].split()
        table[int(name)] = ProcInfo(int(fields[1]), int(fields[2]), fields[0],
                                    int(fields[19]),
                                    stat[stat.find('(') + 1:stat.rfind(')')])
    return table


def alive(pid):
    """Whether process ``pid`` exists and is not a zombie."""
    info = proc_table().get(pid)
    return info is not None and info.live


def descendants(root=None, table=None):
    """{pid: ProcInfo} of the live (not zombie) descendants of ``root``
    (default: this process), from ``table`` (default: /proc now)."""
    table = proc_table() if table is None else table
    root = os.getpid() if root is None else root
    kids = {}
    for pid, info in table.items():
        kids.setdefault(info.ppid, []).append(pid)
    out, todo = {}, list(kids.get(root, []))
    while todo:
        pid = todo.pop()
        if table[pid].live:
            out[pid] = table[pid]
        todo.extend(kids.get(pid, []))
    return out


def cpu_seconds(pid):
    """utime + stime of a process, s (None if gone)."""
    try:
        with open('/proc/%d/stat' % pid) as f:
            fields = f.read().rsplit(')', 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')
    except (OSError, IndexError, ValueError):
        return None


def cmdline(pid, words=3):
    """The first ``words`` words (None: all) of a process's command line,
    base names, for messages; '?' when it is gone."""
    try:
        with open('/proc/%d/cmdline' % pid, 'rb') as f:
            argv = f.read().rstrip(b'\0').split(b'\0')
    except OSError:
        return '?'
    return ' '.join(os.path.basename(a.decode(errors='replace'))
                    for a in argv[:words])


def become_subreaper():
    """Make this process a child subreaper: descendants whose parent died
    are re-parented to it instead of init, so they stay in its tree.
    Returns whether the kernel accepted it."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def reap(children=()):
    """Collect every child of this process that has ended (non-blocking);
    those among ``children`` (Popen objects) through their ``poll()``, so
    they keep their exit status (a plain waitpid(-1) could take it)."""
    mine = {p.pid: p for p in children}
    while True:
        try:
            info = os.waitid(os.P_ALL, 0, os.WEXITED | os.WNOHANG
                             | os.WNOWAIT)
        except ChildProcessError:
            return
        if info is None:
            return
        if info.si_pid in mine:
            mine.pop(info.si_pid).poll()
        else:
            os.waitpid(info.si_pid, 0)


def signal_each(pids, sig):
    """Send ``sig`` to each pid that still exists."""
    for pid in pids:
        try:
            os.kill(pid, sig)
        except (ProcessLookupError, PermissionError):
            pass


def stop_group(proc, timeout=15.0):
    """SIGINT the process group of ``proc`` (a Popen started with
    ``start_new_session``), wait up to ``timeout`` s for it to exit, else
    SIGKILL the group.  Returns its exit status (None if SIGKILL was not
    enough to see it exit within 5 s)."""
    for sig, wait in ((signal.SIGINT, timeout), (signal.SIGKILL, 5.0)):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            pass
        try:
            return proc.wait(timeout=wait)
        except subprocess.TimeoutExpired:
            continue
    return None
