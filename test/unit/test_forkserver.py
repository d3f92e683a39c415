"""The rostests' fork server: a script run through it behaves as a plain
process would, as its parent sees it (argv, environment, folder, streams,
exit status, signals), and anything it cannot serve runs plainly."""
import json
import os
import signal
import subprocess
import sys
import textwrap

import pytest
from hri_sync.tools.procs import alive
from hri_sync_support.fork_protocol import python_settings
from hri_sync_support.harness import wait_until

ROS_PY = '/usr/bin/python3'
SUPPORT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..',
                       'support')
SCRIPT = textwrap.dedent('''\
    import json, os, signal, sys, time
    mode = sys.argv[1]


    def report():
        r = {'argv': sys.argv, 'cwd': os.getcwd(),
             'foo': os.environ.get('FOO'), 'pid': os.getpid(),
             'path0': sys.path[0], 'rospy_before': 'rospy' in sys.modules,
             'numpy_before': 'numpy' in sys.modules,
             'sigint_ignored':
                 signal.getsignal(signal.SIGINT) == signal.SIG_IGN}
        import roslaunch    # preloaded by the server: main(argv=sys.argv)
        r['argv_default'] = roslaunch.main.__defaults__[0]
        print(json.dumps(r), flush=True)


    sys.stderr.write('to stderr\\n')
    if mode == 'sleep':
        try:
            report()
            time.sleep(60)
        except KeyboardInterrupt:
            print('interrupted', flush=True)
            sys.exit(7)
    report()
    if mode == 'exit':
        sys.exit(int(sys.argv[2]))
    if mode == 'raise':
        raise ValueError('boom')
    ''')
DRIVER = textwrap.dedent('''\
    import json, os, signal, subprocess, sys, time
    script, how = sys.argv[1], sys.argv[2]
    if how == 'ignore-int':
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    mode = 'sleep' if how in ('int', 'kill', 'ignore-int') else how
    args = [sys.executable, script, mode] + (['5'] if mode == 'exit' else [])
    p = subprocess.Popen(args, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True,
                         env=dict(os.environ, FOO='bar'))
    first = p.stdout.readline()
    if how in ('int', 'ignore-int'):
        os.kill(p.pid, signal.SIGINT)
        if how == 'ignore-int':
            time.sleep(0.5)
            os.kill(p.pid, signal.SIGTERM)
    elif how == 'kill':
        copy = json.loads(first)['pid']
        os.kill(p.pid, signal.SIGKILL)
    out, err = p.communicate(timeout=240)
    result = {'first': json.loads(first), 'rest': out, 'err': err,
              'code': p.returncode, 'proxy': p.pid}
    if how == 'kill':
        time.sleep(0.5)
        try:
            os.kill(copy, 0)
            state = open('/proc/%d/stat' % copy).read().split()[2]
            result['copy_alive'] = state != 'Z'
        except ProcessLookupError:
            result['copy_alive'] = False
    print(json.dumps(result))
    ''')

pytestmark = pytest.mark.skipif(not os.path.exists(ROS_PY),
                                reason='needs ' + ROS_PY)


def support_env():
    env = dict(os.environ, PYTHONPATH=os.path.abspath(SUPPORT),
               OPENBLAS_NUM_THREADS='1')
    env.pop('PYTHONHOME', None)
    return env


@pytest.fixture(scope='module')
def mother(tmp_path_factory):
    """A mother server's socket (``--mother``), stopped after the tests."""
    path = str(tmp_path_factory.mktemp('mother') / 'mother.sock')
    proc = subprocess.Popen([ROS_PY, '-m', 'hri_sync_support.forkserver',
                             '--mother', path], env=support_env())
    wait_until('the mother\'s socket', lambda: os.path.exists(path), 60,
               [('the mother', proc)], poll=0.05)
    yield path
    proc.terminate()
    assert proc.wait(timeout=30) == 0
    assert not os.path.exists(path)


@pytest.fixture(params=['own', 'mother'])
def server(request):
    """The forkserver arguments before SOCKET: a server of its own, or
    one forked by a mother (the same Server once it runs)."""
    if request.param == 'own':
        return []
    return ['--from', request.getfixturevalue('mother')]


@pytest.fixture
def served(mother):
    """As ``server``, a mother's only: what follows the copy's start is
    the same Server code whoever started it."""
    return ['--from', mother]


def run(tmp_path, how, server=None):
    """The driver's report of the script run ``how``, under a server
    (``server``: the arguments before its socket) or plainly (None)."""
    script = tmp_path / 'script.py'
    script.write_text(SCRIPT)
    driver = tmp_path / 'driver.py'
    driver.write_text(DRIVER)
    env = support_env()
    command = [ROS_PY, str(driver), str(script), how]
    if server is not None:
        command = [ROS_PY, '-m', 'hri_sync_support.forkserver'] + server + [
            str(tmp_path / 'fork.sock'), '--'] + command
    out = subprocess.run(command, cwd=str(tmp_path), env=env, timeout=300,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True,
                         preexec_fn=lambda: signal.signal(
                             signal.SIGINT, signal.default_int_handler))
    # the driver's own failure, with what it and the script wrote
    assert out.returncode == 0, 'driver exit %d\nstdout:\n%s\nstderr:\n%s' % (
        out.returncode, out.stdout, out.stderr)
    return json.loads(out.stdout.splitlines()[-1])


def test_a_served_script_is_a_preloaded_copy_with_the_proxys_settings(
        tmp_path, server):
    served = run(tmp_path, 'exit', server)
    plain = run(tmp_path, 'exit')
    for r in (served, plain):
        assert r['code'] == 5
        assert r['first']['argv'][1:] == ['exit', '5']
        assert r['first']['argv_default'] == r['first']['argv']
        assert r['first']['cwd'] == str(tmp_path)
        assert r['first']['foo'] == 'bar'
        assert r['first']['path0'] == str(tmp_path)
        assert r['err'] == 'to stderr\n'
        assert not r['first']['rospy_before']
    # the copy is not the proxy roslaunch would see, and has numpy already
    assert served['first']['pid'] != served['proxy']
    assert served['first']['numpy_before']
    assert plain['first']['pid'] == plain['proxy']
    assert not plain['first']['numpy_before']


def test_an_uncaught_exception_exits_1_with_its_traceback(tmp_path, served):
    r = run(tmp_path, 'raise', served)
    assert r['code'] == 1
    assert 'ValueError: boom' in r['err']


def test_sigint_to_the_proxy_interrupts_the_copy(tmp_path, served):
    r = run(tmp_path, 'int', served)
    assert r['code'] == 7
    assert r['rest'] == 'interrupted\n'


def test_a_signal_ignored_by_the_proxy_is_ignored_by_the_copy(tmp_path,
                                                              served):
    r = run(tmp_path, 'ignore-int', served)
    assert r['first']['sigint_ignored']
    assert r['code'] == -signal.SIGTERM
    assert 'interrupted' not in r['rest']


def test_a_proxy_killed_takes_its_copy_with_it(tmp_path, served):
    r = run(tmp_path, 'kill', served)
    assert r['code'] == -signal.SIGKILL
    assert r['copy_alive'] is False


def test_without_a_server_the_hook_runs_the_script_plainly(tmp_path):
    script = tmp_path / 'script.py'
    script.write_text(SCRIPT)
    support = os.path.abspath(SUPPORT)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [os.path.join(support, 'forkserver'), support]),
        HRI_SYNC_FORKSERVER=str(tmp_path / 'absent.sock'),
        HRI_SYNC_FORKSERVER_PYTHON=ROS_PY)
    env.pop('PYTHONHOME', None)
    env['HRI_SYNC_FORKSERVER_ENV'] = python_settings(env)
    out = subprocess.run([ROS_PY, str(script), 'exit', '3'], env=env,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, timeout=60)
    assert out.returncode == 3
    assert 'running %s here' % script in out.stderr
    assert json.loads(out.stdout)['argv'][1:] == ['exit', '3']


def test_the_server_exits_with_its_commands_status(tmp_path, server):
    out = subprocess.run(
        [ROS_PY, '-m', 'hri_sync_support.forkserver'] + server + [
            str(tmp_path / 'fork.sock'), '--', 'sh', '-c', 'exit 4'],
        env=support_env(), timeout=120)
    assert out.returncode == 4
    assert not (tmp_path / 'fork.sock').exists()


def test_without_a_mother_the_launcher_serves_itself(tmp_path):
    out = subprocess.run(
        [ROS_PY, '-m', 'hri_sync_support.forkserver', '--from',
         str(tmp_path / 'absent.sock'), str(tmp_path / 'fork.sock'), '--',
         'sh', '-c', 'exit 3'], env=support_env(), timeout=120,
        stderr=subprocess.PIPE, text=True)
    assert out.returncode == 3
    assert 'serving here' in out.stderr


def test_a_killed_launcher_takes_its_server_and_copies_with_it(
        tmp_path, mother):
    # the command: a served script that sleeps, its pid written out
    script = tmp_path / 'sleeper.py'
    script.write_text('import os, time\n'
                      'open(%r, "w").write(str(os.getpid()))\n'
                      'os.rename(%r, %r)\n'       # whole when it appears
                      'time.sleep(120)\n' % tuple(str(tmp_path / f) for f in (
                          'copy.tmp', 'copy.tmp', 'copy.pid')))
    launcher = subprocess.Popen(
        [ROS_PY, '-m', 'hri_sync_support.forkserver', '--from', mother,
         str(tmp_path / 'fork.sock'), '--', ROS_PY, str(script)],
        env=support_env())
    wait_until('the copy\'s pid', (tmp_path / 'copy.pid').exists, 60,
               [('the launcher', launcher)], poll=0.05)
    copy = int((tmp_path / 'copy.pid').read_text())
    launcher.kill()
    launcher.wait()
    wait_until('the copy to end', lambda: not alive(copy), 30, poll=0.05)
    assert not (tmp_path / 'fork.sock').exists()


def test_a_copy_remembers_the_nodes_it_found(monkeypatch):
    import roslib.packages
    from hri_sync_support import forkserver
    calls = []

    def find_node(pkg, node_type, rospack=None):
        calls.append(node_type)
        return [] if node_type == 'missing' \
            else ['/lib/%s/%s' % (pkg, node_type)]
    monkeypatch.setattr(roslib.packages, 'find_node', find_node)
    forkserver.remember_nodes()
    for _ in range(3):
        assert roslib.packages.find_node('hri_sync', 'cm', rospack=object()) \
            == ['/lib/hri_sync/cm']
        assert roslib.packages.find_node('hri_sync', 'missing') == []
    roslib.packages.find_node('hri_sync', 'cm').append('changed')
    assert roslib.packages.find_node('hri_sync', 'cm') == ['/lib/hri_sync/cm']
    assert calls == ['cm', 'missing', 'missing', 'missing']


def test_the_preload_is_every_core_package_and_brings_no_rospy():
    """CORE names every subpackage but the ROS shell and the tools (a
    package moved or added is preloaded too), and preloading them, their
    ros_*.py sides left out, does not import rospy."""
    import pkgutil

    import hri_sync
    from hri_sync_support import forkserver
    packages = {'hri_sync.' + m.name
                for m in pkgutil.iter_modules(hri_sync.__path__)
                if m.ispkg and m.name not in ('ros', 'tools', 'msg')}
    assert set(forkserver.CORE) == packages
    code = ('import sys; from hri_sync_support import forkserver as f; '
            'f.remember_nodes = lambda: None; f.preload(); '
            'print(sorted(m for m in sys.modules if m.startswith("hri_sync.")'
            ' and m.rsplit(".", 1)[1].startswith("ros_")))')
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [SUPPORT, os.path.join(SUPPORT, '..', 'src'),
         os.environ.get('PYTHONPATH', '')]))
    out = subprocess.run([ROS_PY, '-c', code], env=env, capture_output=True,
                         text=True, check=True).stdout
    assert out.strip() == '[]'
