"""What the rostests' fork server (``forkserver``) and its startup hook
(``support/forkserver/sitecustomize.py``) agree on: names, and the framing
of their messages.  Imported by the hook in every Python process under a
server, so its functions import what they use when called.

A request is a 4-byte length, its JSON, and the sender's standard streams
(fds 0, 1, 2, passed with the length); an answer (a pid, an exit status)
is a 4-byte signed int."""

ENV = 'HRI_SYNC_FORKSERVER'      # the server's socket (or 'off')
ENV_PYTHON = ENV + '_PYTHON'     # the server's interpreter
ENV_SETTINGS = ENV + '_ENV'      # its python_settings
# The signals a proxy passes on to its copy, and whose disposition (ignored
# or not) the copy takes from it.
FORWARDED = ('SIGINT', 'SIGTERM', 'SIGHUP', 'SIGQUIT', 'SIGUSR1', 'SIGUSR2',
             'SIGCONT')


def python_settings(env):
    """The PYTHON* variables a process must share with the server to be
    served (its ``PYTHONPATH`` may differ: a copy's path is built from
    its own)."""
    return repr(sorted((k, v) for k, v in env.items()
                       if k.startswith('PYTHON') and k != 'PYTHONPATH'))


def send_request(conn, request):
    """Sends ``request`` with this process's standard streams."""
    import json
    import socket
    import struct
    body = json.dumps(request).encode()
    conn.sendmsg([struct.pack('!I', len(body)), body],
                 [(socket.SOL_SOCKET, socket.SCM_RIGHTS,
                   struct.pack('3i', 0, 1, 2))])


def receive_request(conn):
    """(request, [fd 0, fd 1, fd 2]) of the sender; EOFError when it
    closed first or sent no 3 streams."""
    import json
    import socket
    import struct
    head, fds = b'', []
    while len(head) < 4:
        data, ancdata, _, _ = conn.recvmsg(4 - len(head),
                                           socket.CMSG_SPACE(3 * 4))
        if not data:
            raise EOFError('the sender closed before its request')
        head += data
        for level, kind, payload in ancdata:
            if level == socket.SOL_SOCKET and kind == socket.SCM_RIGHTS:
                fds += list(struct.unpack('%di' % (len(payload) // 4),
                                          payload))
    size = struct.unpack('!I', head)[0]
    body = b''
    while len(body) < size:
        chunk = conn.recv(size - len(body))
        if not chunk:
            raise EOFError('the sender closed mid-request')
        body += chunk
    if len(fds) != 3:
        raise EOFError('the sender sent %d streams, not 3' % len(fds))
    return json.loads(body), fds


def send_int(conn, value):
    import struct
    conn.sendall(struct.pack('!i', value))


def receive_int(conn):
    """The int sent, or None when the other side closed first."""
    import socket
    import struct
    data = conn.recv(4, socket.MSG_WAITALL)
    return struct.unpack('!i', data)[0] if len(data) == 4 else None
