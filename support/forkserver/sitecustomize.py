"""Hands a Python script over to the rostests' fork server, if one serves.

On the ``PYTHONPATH`` of a rostest run by ``scripts/run_rostests.py``
only (never installed); what it shares with the server is
``hri_sync_support.fork_protocol``.  Python imports this at startup.  When
``HRI_SYNC_FORKSERVER`` names the socket of ``hri_sync_support.forkserver``
and this process runs a script plainly (``python3 SCRIPT ARGS``, no
interpreter option, the server's interpreter and ``PYTHON*`` variables,
no ``LD_PRELOAD``: faketime's clients run as they are), this process
becomes the script's proxy: it sends its argv, environment, working
folder and standard streams, and the server forks a copy of itself,
rospy's dependencies already imported, to run the script.  The proxy
passes on every signal it gets to the copy's process group and ends as
the copy ends (its exit code, or killed by its signal); a signal it
ignores, the copy ignores too.  Anything else,
and any failure to reach the server, runs the script here as usual.
Debian's own sitecustomize (an apport hook, absent here) is shadowed.
"""
import os
import sys


def _plain_script():
    """The script's path when this is ``python3 SCRIPT ARGS``, else None."""
    argv = sys.argv
    if not argv or argv[0] in ('', '-c', '-m', '-'):
        return None
    if getattr(sys, 'orig_argv', [None])[1:] != argv:
        return None     # interpreter options
    return argv[0] if os.path.isfile(argv[0]) else None


def _same_interpreter(env, protocol):
    """This interpreter and its PYTHON* settings (but its path) are the
    server's."""
    return (env.get(protocol.ENV_PYTHON) == sys.executable
            and env.get(protocol.ENV_SETTINGS)
            == protocol.python_settings(env)
            and 'LD_PRELOAD' not in env and sys.prefix == sys.base_prefix)


def _hand_over(path, script, protocol):
    """Runs ``script`` in the server: never returns once it started."""
    import signal
    import socket
    forwarded = protocol.FORWARDED
    for fd in (0, 1, 2):
        os.fstat(fd)        # OSError: a closed stream, run here
    conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    conn.connect(path)
    # Signals wait until they can be passed on (a SIGINT now would
    # otherwise leave the script running both here and there).
    # A signal ignored here stays ignored, here and in the copy.
    ignored = [getattr(signal, name) for name in forwarded
               if signal.getsignal(getattr(signal, name)) == signal.SIG_IGN]
    signals = [getattr(signal, name) for name in forwarded
               if getattr(signal, name) not in ignored]
    signal.pthread_sigmask(signal.SIG_BLOCK, signals)
    try:
        protocol.send_request(conn, {
            'argv': sys.argv, 'cwd': os.getcwd(), 'env': dict(os.environ),
            'ignored': [int(s) for s in ignored]})
        pid = protocol.receive_int(conn)
        if pid is None:
            raise OSError('the fork server did not start %s' % script)
    except BaseException:
        conn.close()
        signal.pthread_sigmask(signal.SIG_UNBLOCK, signals)
        raise

    def forward(signum, _frame):
        try:
            os.killpg(pid, signum)
        except ProcessLookupError:
            pass
    for signum in signals:
        signal.signal(signum, forward)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, signals)
    status = protocol.receive_int(conn)
    if status is None:
        sys.stderr.write('hri_sync forkserver: lost the server running %s\n'
                         % script)
        os._exit(1)
    if os.WIFSIGNALED(status):
        sig = os.WTERMSIG(status)
        signal.signal(sig, signal.SIG_DFL)
        os.kill(os.getpid(), sig)
        os._exit(128 + sig)
    os._exit(os.waitstatus_to_exitcode(status))


def _main():
    try:
        from hri_sync_support import fork_protocol
    except ImportError:
        return      # support/ not on the path: no server of ours
    path = os.environ.get(fork_protocol.ENV, '')
    script = _plain_script()
    if not os.path.isabs(path) or script is None \
            or not _same_interpreter(os.environ, fork_protocol):
        return
    try:
        _hand_over(path, script, fork_protocol)
    except OSError as e:
        sys.stderr.write('hri_sync forkserver: %s; running %s here\n'
                         % (e, script))


_main()
