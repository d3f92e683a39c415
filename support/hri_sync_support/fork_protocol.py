"""What the rostests' fork server (``forkserver``) and its startup hook
(``support/forkserver/sitecustomize.py``) agree on.  Imported by the hook
in every Python process under a server: nothing but names here."""

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
