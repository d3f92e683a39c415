"""Run a tool under a Python that has the libraries it needs.

ROS runs nodes with /usr/bin/python3; the PyPI-only ``rosbags`` and
``pylsl`` live in the package's venv (``make venv``).
``ensure(modules, prog, script)`` returns if every module imports, else
re-executes ``script`` under the first venv that exists
(``$HRI_SYNC_VENV``, the source tree's ``.venv`` when ``script`` runs from
one, the ROS package's ``.venv``, an install space's
``share/hri_sync/venv`` made by ``catkin_make install``), or exits with
what to install.
"""
import importlib
import os
import sys


def _missing(modules):
    out = []
    for m in modules:
        try:
            importlib.import_module(m)
        except ImportError:
            out.append(m)
    return out


def ensure(modules, prog, script):
    """Import ``modules`` or re-exec ``script`` (with sys.argv) in a venv."""
    missing = _missing(modules)
    if not missing:
        return
    source = os.path.dirname(os.path.dirname(os.path.realpath(script)))
    candidates = [os.environ.get('HRI_SYNC_VENV', '')]
    if os.path.exists(os.path.join(source, 'package.xml')):
        candidates.append(os.path.join(source, '.venv'))
    try:
        import rospkg
        share = rospkg.RosPack().get_path('hri_sync')
        # A workspace's package folder links its files to the source
        # folder, which holds .venv.
        real = os.path.dirname(os.path.realpath(
            os.path.join(share, 'package.xml')))
        candidates += [os.path.join(real, '.venv'),
                       os.path.join(share, 'venv')]
    except Exception:   # no ROS environment: the other candidates remain
        pass
    if not os.environ.get('HRI_SYNC_REEXEC'):
        for venv in candidates:
            python = os.path.join(venv, 'bin', 'python') if venv else ''
            if python and os.access(python, os.X_OK) and \
                    os.path.realpath(sys.prefix) != os.path.realpath(venv):
                os.environ['HRI_SYNC_REEXEC'] = '1'
                os.execv(python, [python, os.path.realpath(script)]
                         + sys.argv[1:])
    sys.exit('%s: the Python libraries %s are missing (looked for a venv '
             'with them in %s). In the hri_sync source folder run "make '
             'setup", or anywhere: pip install rosbags matplotlib numpy pylsl '
             'pyyaml' % (prog, ', '.join(missing),
                         ', '.join(c for c in candidates if c) or 'none'))
