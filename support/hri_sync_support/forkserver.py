"""A fork server for a rostest's Python processes (test tooling only).

    python3 -m hri_sync_support.forkserver SOCKET -- COMMAND ...
    python3 -m hri_sync_support.forkserver --mother MOTHER
    python3 -m hri_sync_support.forkserver --from MOTHER SOCKET -- COMMAND ...

A rostest starts ~15 Python processes, and each spends ~0.35 CPU s
importing rospy's dependencies (numpy, genpy, yaml, catkin_pkg, the
message modules) before it does anything: on a 2-core machine that is
about half of the suite's CPU.  This server imports them once, then runs
COMMAND with ``support/forkserver`` on its ``PYTHONPATH`` and
``HRI_SYNC_FORKSERVER=SOCKET``; every Python script started under it
(rostest, rosmaster, the nodes, the checkers) hands itself over
(``support/forkserver/sitecustomize.py``) and the server forks a copy to
run it: the script's own code, argv, environment, folder and streams, in
a session of its own, while its proxy stands where roslaunch started it
(its pid, signals and exit status).  rospy itself is not imported here:
it reads argv and the environment at import, so each copy imports it
(~0.02 CPU s).  The server exits with COMMAND's status, after SIGKILL to
any copy left.

A suite of rostests starts one mother (``--mother``), which imports them
once for all the tests; each test's ``--from`` asks it for a server, which
the mother forks and moves into the asking process's network namespace
and cgroups, and which then serves as above (the asking process waits
and exits with COMMAND's status; killed, it takes the server and its
copies with it).  Without a mother to reach, ``--from`` serves itself.

What differs from a plain process, and where it matters: a copy's parent
is this server, not roslaunch, so a lifeline (PR_SET_PDEATHSIG) fires
when the server ends, not when roslaunch dies; a test about process
lifetimes runs its launch with ``HRI_SYNC_FORKSERVER`` set to ``off``.
"""
import atexit
import ctypes
import importlib
import os
import pkgutil
import runpy
import selectors
import signal
import socket
import subprocess
import sys
import threading
import traceback

from hri_sync_support.fork_protocol import (
    ENV, ENV_PYTHON, ENV_SETTINGS, FORWARDED, python_settings,
    receive_int, receive_request, send_int, send_request)

os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')  # no thread to fork

# rospy's dependencies that hold no state of the process (rospy, which
# reads argv and the environment at import, is left to each copy).
PRELOAD = ('numpy', 'yaml', 'genpy', 'genpy.rostime', 'roslib',
           'roslib.packages', 'rosgraph', 'rosgraph.masterapi',
           'rosgraph.network', 'rospkg', 'catkin_pkg.package',
           'xmlrpc.client', 'xmlrpc.server', 'http.server',
           'logging.config', 'socketserver', 'std_msgs.msg',
           'geometry_msgs.msg', 'sensor_msgs.msg', 'diagnostic_msgs.msg',
           'visualization_msgs.msg', 'tf2_msgs.msg', 'nav_msgs.msg',
           'rosgraph_msgs.msg', 'hri_sync.msg',
           # rostest's own: roslaunch pulls in setuptools (0.35 CPU s)
           'roslaunch', 'rostest')
# hri_sync's core packages: no rospy, no process state (test_layers.py);
# their ROS sides (ros_*.py) are left to each copy, as rospy is.
CORE = ('hri_sync.wire', 'hri_sync.clock', 'hri_sync.control',
        'hri_sync.decision', 'hri_sync.client_process',
        'hri_sync.data_process', 'hri_sync.dance_off', 'hri_sync.robot',
        'hri_sync.people', 'hri_sync.sensors')
PR_SET_NAME = 15
CLONE_NEWNET = 0x40000000
_KEEP = []  # the server's objects a copy must not close on collection


def preload():
    """Import PRELOAD and CORE's modules (those that import here); rospy
    must not come with them."""
    names = list(PRELOAD)
    for package in CORE:
        try:
            path = importlib.import_module(package).__path__
        except ImportError:
            continue
        names += [m.name for m in pkgutil.iter_modules(path, package + '.')
                  if not m.name.rsplit('.', 1)[1].startswith('ros_')]
    for name in names:
        try:
            importlib.import_module(name)
        except ImportError:
            pass    # e.g. pylsl, which only the venv has
    if 'rospy' in sys.modules:
        raise RuntimeError('a preloaded module imported rospy')
    remember_nodes()


def remember_nodes():
    """roslaunch looks each node's executable up with a RosPack of its
    own (a crawl of the package path and a parse of package.xml, ~20 CPU
    ms a node, ~15 nodes a test): a copy remembers each (package, type)
    it found.  Nothing installs a node while a test runs."""
    import roslib.packages
    find = roslib.packages.find_node
    found = {}

    def find_node(pkg, node_type, rospack=None):
        if (pkg, node_type) not in found:
            matches = find(pkg, node_type, rospack=rospack)
            if not matches:
                return matches
            found[pkg, node_type] = matches
        return list(found[pkg, node_type])
    roslib.packages.find_node = find_node


def _listen(path):
    """A Unix socket listening at ``path`` (a file left there by a server
    killed before it could remove it is replaced)."""
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    if os.path.exists(path):
        os.unlink(path)
    listener.bind(path)
    listener.listen(64)
    return listener


def _unlisten(listener, path):
    listener.close()
    try:
        os.unlink(path)
    except OSError:
        pass


def _request(conn):
    """receive_request, or (None, None) after saying why (``conn``
    closed)."""
    try:
        return receive_request(conn)
    except (OSError, EOFError, ValueError) as e:
        sys.stderr.write('hri_sync forkserver: %s\n' % e)
        conn.close()
        return None, None


class Server:
    """Forks a copy per proxy; reports each copy's end to its proxy."""

    def __init__(self, path):
        self.path = path
        self.listener = _listen(path)
        self.selector = selectors.DefaultSelector()
        self.selector.register(self.listener, selectors.EVENT_READ)
        self.copies = {}     # pid: (its proxy's connection, its pidfd)
        self.main_fd = None
        self.launcher = None
        # sys.path without -m's working folder and PYTHONPATH's entries
        pythonpath = [p for p in os.environ.get('PYTHONPATH', '').split(
            os.pathsep) if p]
        self.base_path = [p for p in sys.path[1:] if p not in pythonpath]

    def serve(self, command, launcher=None):
        """Runs ``command`` under the server; its exit status (None when
        the ``launcher`` connection, if given, closed first)."""
        env = dict(os.environ)
        hook = os.path.join(os.path.dirname(os.path.dirname(
            os.path.abspath(__file__))), 'forkserver')
        env['PYTHONPATH'] = os.pathsep.join(
            [hook] + [p for p in env.get('PYTHONPATH', '').split(os.pathsep)
                      if p])
        env.update({ENV: self.path, ENV_PYTHON: sys.executable,
                    ENV_SETTINGS: python_settings(env)})
        main = subprocess.Popen(command, env=env)
        self.main_fd = os.pidfd_open(main.pid)
        self.selector.register(self.main_fd, selectors.EVENT_READ, 'main')
        if launcher is not None:
            self.launcher = launcher
            self.selector.register(launcher, selectors.EVENT_READ,
                                   'launcher')
        while True:
            for key, _ in self.selector.select():
                if key.fileobj is self.listener:
                    self.accept()
                elif key.data == 'main':
                    return main.wait()      # main() closes the server
                elif key.data == 'launcher':
                    main.kill()
                    main.wait()
                    return None
                elif key.data[0] == 'copy':
                    self.copy_ended(key.data[1])
                else:
                    self.proxy_gone(key.data[1])

    def accept(self):
        conn, _ = self.listener.accept()
        request, fds = _request(conn)
        if request is None:
            return
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:
            self.run_copy(conn, request, fds)
        for fd in fds:
            os.close(fd)
        pidfd = os.pidfd_open(pid)
        self.copies[pid] = (conn, pidfd)
        self.selector.register(pidfd, selectors.EVENT_READ, ('copy', pid))
        self.selector.register(conn, selectors.EVENT_READ, ('proxy', pid))
        try:
            send_int(conn, pid)
        except OSError:
            self.proxy_gone(pid)

    def copy_ended(self, pid):
        _, status = os.waitpid(pid, 0)
        conn, pidfd = self.copies.pop(pid)
        self.selector.unregister(pidfd)
        if conn.fileno() in self.selector.get_map():
            self.selector.unregister(conn)
        os.close(pidfd)
        try:
            send_int(conn, status)
        except OSError:
            pass
        conn.close()

    def proxy_gone(self, pid):
        """The proxy closed (killed: SIGKILL cannot be passed on): the copy
        and its process group get SIGKILL too."""
        conn, _ = self.copies[pid]
        self.selector.unregister(conn)
        try:
            os.killpg(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass

    def close(self):
        """SIGKILL to every copy left; the socket removed."""
        for pid in list(self.copies):
            try:
                os.killpg(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        _unlisten(self.listener, self.path)

    def run_copy(self, conn, request, fds):
        """In the forked copy: become the script's process; never returns."""
        code = 1
        try:
            os.setsid()
            theirs = [self.listener, conn] + [
                c for c, _ in self.copies.values()] + (
                    [self.launcher] if self.launcher else [])
            _KEEP.extend(theirs + [self.selector])
            for fd in [c.fileno() for c in theirs] + [
                    p for _, p in self.copies.values()] + [self.main_fd]:
                os.close(fd)
            self.selector.close()
            _adopt(request, fds)
            sys.stdout.reconfigure(line_buffering=os.isatty(1))
            _signals(request.get('ignored', []))
            argv = request['argv']
            # in place: a preloaded function's default may be this list
            # (roslaunch.main(argv=sys.argv), rosmaster_main's)
            sys.argv[:] = argv
            sys.orig_argv[:] = [sys.executable] + argv
            script = os.path.realpath(argv[0])
            _name(os.path.basename(argv[0]))
            sys.path[:] = [os.path.dirname(script)] + [
                p for p in os.environ.get('PYTHONPATH', '').split(os.pathsep)
                if p] + self.base_path
            code = _run(argv[0])
        finally:
            try:
                sys.stdout.flush()
                sys.stderr.flush()
            finally:
                os._exit(code)


class Mother:
    """Forks a Server per launcher (``--from``), in the launcher's
    network namespace and cgroups, with its streams, environment and
    folder."""

    def __init__(self, path):
        self.path = path
        self.listener = _listen(path)

    def serve(self):
        """Until SIGTERM or SIGINT."""
        signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
        self.listener.settimeout(1.0)
        try:
            while True:
                _reap()
                try:
                    conn, _ = self.listener.accept()
                except socket.timeout:
                    continue
                conn.settimeout(None)
                request, fds = _request(conn)
                if request is None:
                    continue
                if os.fork() == 0:
                    self.run_server(conn, request, fds)
                for fd in fds:
                    os.close(fd)
                conn.close()
        finally:
            _unlisten(self.listener, self.path)

    def run_server(self, conn, request, fds):
        """In the forked server: serve the launcher's command, send its
        status; never returns."""
        code = 1
        try:
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
            os.setsid()
            self.listener.close()
            _join(request['pid'])
            send_int(conn, os.getpid())    # ready
            _adopt(request, fds)
            server = Server(request['path'])
            try:
                status = server.serve(request['command'], launcher=conn)
            finally:
                server.close()
            if status is not None:
                send_int(conn, status)
            code = 0
        except BaseException:
            traceback.print_exc()
        finally:
            os._exit(code)


def _adopt(request, fds):
    """Takes the sender's standard streams, folder and environment."""
    for target, fd in enumerate(fds):
        os.dup2(fd, target)
        os.close(fd)
    os.chdir(request['cwd'])
    os.environ.clear()
    os.environ.update(request['env'])


def _reap():
    """Collects the mother's servers that ended."""
    try:
        while os.waitpid(-1, os.WNOHANG)[0]:
            pass
    except ChildProcessError:
        pass


def _join(pid):
    """Moves this process into process ``pid``'s network namespace and
    cgroups (those that differ from its own)."""
    mine = '/proc/self/ns/net'
    theirs = '/proc/%d/ns/net' % pid
    if os.stat(mine).st_ino != os.stat(theirs).st_ino:
        libc = ctypes.CDLL(None, use_errno=True)
        fd = os.open(theirs, os.O_RDONLY)
        try:
            if libc.setns(fd, CLONE_NEWNET) != 0:
                raise OSError(ctypes.get_errno(), 'setns %s' % theirs)
        finally:
            os.close(fd)

    def groups(path):
        with open(path) as f:
            return dict(line.rstrip('\n').split(':', 2)[1:] for line in f)
    own = groups('/proc/self/cgroup')
    for controllers, group in groups('/proc/%d/cgroup' % pid).items():
        if own.get(controllers) == group:
            continue
        root = os.path.join('/sys/fs/cgroup', controllers or 'unified')
        with open(os.path.join(root, group.lstrip('/'), 'cgroup.procs'),
                  'w') as f:
            f.write(str(os.getpid()))


def launch(mother, path, command):
    """Runs ``command`` under a server the mother at ``mother`` forks for
    this process; serves it here when there is no mother to reach."""
    conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        conn.connect(mother)
        send_request(conn, {'pid': os.getpid(), 'path': path,
                            'command': command, 'cwd': os.getcwd(),
                            'env': dict(os.environ)})
        if receive_int(conn) is None:
            raise OSError('no server started here (the mother says why)')
    except OSError as e:
        sys.stderr.write('hri_sync forkserver: mother %s: %s; serving '
                         'here\n' % (mother, e))
        conn.close()
        return serve_here(path, command)
    status = receive_int(conn)
    if status is None:
        sys.stderr.write('hri_sync forkserver: lost the server of %s\n'
                         % mother)
        return 1
    return status


def serve_here(path, command):
    """Preloads, serves ``command``; its status."""
    preload()
    server = Server(path)
    try:
        return server.serve(command)
    finally:
        server.close()


def _name(name):
    """The process's name (``ps -o comm``, ``top``): the script's, as a
    plain process's would be (its command line stays the server's)."""
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(PR_SET_NAME, name.encode()[:15], 0, 0, 0)


def _signals(ignored):
    """The dispositions Python starts with, as the proxy had them:
    ``ignored`` (signal numbers) ignored, SIGINT raising
    KeyboardInterrupt, the rest by default."""
    for name in FORWARDED:
        signum = getattr(signal, name)
        if signum in ignored:
            signal.signal(signum, signal.SIG_IGN)
        elif signum == signal.SIGINT:
            signal.signal(signum, signal.default_int_handler)
        else:
            signal.signal(signum, signal.SIG_DFL)


def _run(script):
    """Runs ``script`` as ``__main__`` and ends as Python would: threads
    joined, atexit handlers run; the exit code (an uncaught
    KeyboardInterrupt ends the process by SIGINT, as Python's does)."""
    interrupted = False
    code = 0
    try:
        runpy.run_path(script, run_name='__main__')
    except SystemExit as e:
        if e.code is None:
            code = 0
        elif isinstance(e.code, int):
            code = e.code
        else:
            sys.stderr.write('%s\n' % e.code)
            code = 1
    except KeyboardInterrupt:
        traceback.print_exc()
        interrupted = True
    except BaseException:
        traceback.print_exc()
        code = 1
    threading._shutdown()
    atexit._run_exitfuncs()
    if interrupted:
        sys.stdout.flush()
        sys.stderr.flush()
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        os.kill(os.getpid(), signal.SIGINT)
    return code


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) == 2 and argv[0] == '--mother':
        preload()
        Mother(argv[1]).serve()
        return 0
    mother = None
    if argv[:1] == ['--from'] and len(argv) > 1:
        mother, argv = argv[1], argv[2:]
    if len(argv) < 3 or argv[1] != '--':
        sys.stderr.write(__doc__.split('\n\n')[1] + '\n')
        return 2
    path, command = argv[0], argv[2:]
    if mother:
        return launch(mother, path, command)
    return serve_here(path, command)


if __name__ == '__main__':
    sys.exit(main())
