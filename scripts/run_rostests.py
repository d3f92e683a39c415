#!/usr/bin/python3
"""Run every rostest in a folder, one after another, and summarise.

    run_rostests.py TEST_DIR [NAME_SUBSTRING ...]

Runs TEST_DIR/rostest/*.test with rostest, then the script-driven tests,
TEST_DIR/system/test_*.py, with pytest: those need what rostest cannot
give (e.g. a master they restart) and start their own processes.  Each
test's full output goes to .ws/test_logs/<name>.log; a failing test's
tail is printed.  The last line is 'rostest: N passed, N failed'; the exit
status is non-zero when any test failed or none ran.
"""
import glob
import os
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

TIMEOUT = 600  # s per test file


def junit_counts(path):
    """(tests, failures + errors) of a JUnit XML file, or None."""
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError):
        return None
    suites = [root] if root.tag == 'testsuite' else root.findall('testsuite')
    tests = sum(int(s.get('tests', 0)) for s in suites)
    bad = sum(int(s.get('failures', 0)) + int(s.get('errors', 0))
              for s in suites)
    return tests, bad


def restore_signals():
    """SIGINT and SIGQUIT back to their defaults when this script was
    started with them ignored (in the background by a non-interactive
    shell): the tests' processes inherit them, and roslaunch and the
    checkers stop nodes with SIGINT."""
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    if signal.getsignal(signal.SIGQUIT) == signal.SIG_IGN:
        signal.signal(signal.SIGQUIT, signal.SIG_DFL)


def main():
    restore_signals()
    test_dir = os.path.abspath(sys.argv[1])
    wanted = sys.argv[2:]
    root = os.path.dirname(test_dir)
    logs = os.path.join(root, '.ws', 'test_logs')
    results = os.path.join(root, '.ws', 'test_results')
    os.makedirs(logs, exist_ok=True)
    files = sorted(glob.glob(os.path.join(test_dir, 'rostest', '*.test'))) + \
        sorted(glob.glob(os.path.join(test_dir, 'system', 'test_*.py')))
    files = [f for f in files if not wanted or any(w in f for w in wanted)]
    passed, failed = [], []
    for f in files:
        name = os.path.splitext(os.path.basename(f))[0]
        log = os.path.join(logs, name + '.log')
        xml = os.path.join(results, 'hri_sync', 'rostest-%s.xml' % name)
        if f.endswith('.py'):
            command = [sys.executable, '-m', 'pytest', '-q', '-p',
                       'no:cacheprovider', '--junitxml', xml, f]
        else:
            command = ['rostest', '--results-base-dir', results,
                       '--results-filename', '%s.xml' % name,
                       'hri_sync', os.path.basename(f)]
        if os.path.exists(xml):
            os.remove(xml)
        t0 = time.monotonic()
        with open(log, 'w') as out:
            try:
                code = subprocess.run(
                    command, stdout=out, stderr=subprocess.STDOUT,
                    timeout=TIMEOUT).returncode
            except subprocess.TimeoutExpired:
                code = 'timeout after %d s' % TIMEOUT
        counts = junit_counts(xml)
        ok = code == 0 and counts is not None and counts[0] > 0 \
            and counts[1] == 0
        print('%-4s %-40s %6.1f s  (exit %s, %s)' % (
            'PASS' if ok else 'FAIL', name, time.monotonic() - t0, code,
            '%d tests, %d failed' % counts if counts else 'no result file'),
            flush=True)
        if not ok:
            with open(log) as lf:
                tail = lf.readlines()[-40:]
            print('  --- tail of %s ---' % log)
            sys.stdout.write(''.join('  ' + line for line in tail))
            failed.append(name)
        else:
            passed.append(name)
    print('rostest: %d passed, %d failed' % (len(passed), len(failed)))
    sys.exit(1 if failed or not passed else 0)


if __name__ == '__main__':
    main()
