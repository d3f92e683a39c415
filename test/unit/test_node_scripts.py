"""Every executable in nodes/ is a shell: it reads its params, wires its
topics and calls the core, in at most 150 lines (the logic lives in
src/hri_sync, in a module's core or its ros_*.py shell)."""
import glob
import os

MAX_LINES = 150
NODES = os.path.join(os.path.dirname(__file__), '..', '..', 'nodes')


def test_every_node_script_is_short():
    long = []
    for path in sorted(glob.glob(os.path.join(NODES, '*'))):
        if os.path.isfile(path):
            with open(path) as f:
                n = sum(1 for _ in f)
            if n > MAX_LINES:
                long.append('%s: %d lines' % (os.path.basename(path), n))
    assert long == [], 'move the logic into src/hri_sync: ' + ', '.join(long)


def test_no_node_script_carries_the_run_bit():
    """rosrun finds the devel (or install) relay of each node; a run bit
    in nodes/ would make a second copy and the choice ambiguous."""
    marked = [os.path.basename(p) for p in glob.glob(os.path.join(NODES, '*'))
              if os.stat(p).st_mode & 0o111]
    assert marked == [], 'chmod a-x ' + ' '.join(marked)
