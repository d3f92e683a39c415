"""scripts/test_under_load.py on a stand-in checkout (a tiny Makefile)."""

import json
import os
import subprocess
import sys

SCRIPT = os.path.join(os.path.dirname(__file__), '..', '..', 'scripts',
                      'test_under_load.py')

MAKEFILE = """\
good:
\t@echo all fine
bad:
\t@echo 'FAILED test/unit/test_x.py::test_y - AssertionError'
\t@echo 'FAIL dj_rob_left                        12.0 s  (exit 1)'
\t@echo 'make[1]: *** [Makefile:50: check] Error 1'
\t@exit 2
"""


def run(tmp_path, *args):
    (tmp_path / 'Makefile').write_text(MAKEFILE)
    res = subprocess.run(
        [sys.executable, SCRIPT, '--checkout', str(tmp_path)] + list(args),
        stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        universal_newlines=True, timeout=60)
    return res, json.loads(res.stdout.splitlines()[-1])


def gone(pid):
    """True unless ``pid`` is a live busy loop (the pid may be reused)."""
    try:
        with open('/proc/%d/stat' % pid) as f:
            if f.read().split(') ')[1][0] == 'Z':
                return True
        with open('/proc/%d/cmdline' % pid) as f:
            return 'while True' not in f.read()
    except (FileNotFoundError, ProcessLookupError):
        return True


def test_passing_runs_with_busy_loops(tmp_path):
    res, summary = run(tmp_path, '--target', 'good', '--runs', '2',
                       '--loops', '2')
    assert res.returncode == 0, res.stderr
    assert summary['passed'] is True
    assert [r['run'] for r in summary['runs']] == [1, 2]
    for r in summary['runs']:
        assert r['passed'] and r['exit'] == 0 and r['failed'] == []
        assert r['busy_loops_alive'] == 2
        assert os.path.exists(r['log'])
    assert len(summary['busy_loop_pids']) == 2
    assert all(gone(p) for p in summary['busy_loop_pids'])


def test_failed_run_names_its_failures_and_stops_the_loops(tmp_path):
    res, summary = run(tmp_path, '--target', 'bad', '--runs', '1',
                       '--loops', '1')
    assert res.returncode == 1
    assert summary['passed'] is False
    (r,) = summary['runs']
    assert not r['passed'] and r['exit'] != 0
    assert r['failed'] == ['test/unit/test_x.py::test_y', 'dj_rob_left',
                           'check']
    assert all(gone(p) for p in summary['busy_loop_pids'])


def test_bad_arguments_refused(tmp_path):
    res = subprocess.run([sys.executable, SCRIPT, '--runs', '0'],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         universal_newlines=True, timeout=60)
    assert res.returncode == 2
    assert '--runs must be >= 1' in res.stderr
