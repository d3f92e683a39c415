"""The layer order of src/hri_sync (docs/architecture.md, "Layers"), from
the imports: a layer imports only itself and the layers below it, only the
shell imports ROS (rospy, the generated messages, ...), and no module
imports itself back through others.

    wire  <  clock  <  control, decision, client_process, data_process
          <  dance_off, people, sensors  <  robot, fusion  <  tools  <  shell

The shell is ``hri_sync.ros`` (what the nodes share) and every module
named ``ros_*.py`` (a module's ROS side, kept beside its core).  ``wire``
imports nothing of the package; the paper's four modules share a layer,
as do ``people``, ``sensors`` and ``dance_off``, and ``robot`` and
``fusion``.
"""
import ast
import glob
import os

import pytest

SRC = os.path.join(os.path.dirname(__file__), '..', '..', 'src', 'hri_sync')
RANK = {'wire': 0, 'clock': 1, 'control': 2, 'decision': 2,
        'client_process': 2, 'data_process': 2, 'dance_off': 3,
        'people': 3, 'sensors': 3, 'robot': 4, 'fusion': 4, 'tools': 5,
        'ros': 6}
SHELL = 6
ROS = ('rospy', 'rosbag', 'roslib', 'rosgraph', 'genpy', 'rostopic',
       'hri_sync.msg', 'hri_sync.srv', 'std_msgs', 'sensor_msgs',
       'geometry_msgs', 'diagnostic_msgs', 'tf2_ros')


def module_name(path):
    rel = os.path.relpath(path, SRC)[:-len('.py')].split(os.sep)
    return '.'.join(['hri_sync'] + rel)


def imports(path):
    """Every module name ``path`` imports (at any depth, lazily too)."""
    with open(path) as f:
        tree = ast.parse(f.read())
    package = module_name(path).rsplit('.', 1)[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:          # relative: within its own package
                yield '%s.%s' % (package, node.module or '')
            else:
                yield node.module


def modules():
    return sorted(glob.glob(os.path.join(SRC, '*', '*.py')))


def is_shell(name):
    parts = name.split('.')
    return parts[1] == 'ros' or parts[-1].startswith('ros_')


def rank_of(name):
    """The layer of module ``name`` (None: not of the package)."""
    parts = name.split('.')
    if parts[0] != 'hri_sync' or len(parts) < 2 or parts[1] not in RANK:
        return None
    return SHELL if is_shell(name) else RANK[parts[1]]


def violations(path):
    name = module_name(path)
    package = name.split('.')[1]
    out = []
    for other in imports(path):
        if not is_shell(name) and any(other == r or other.startswith(r + '.')
                                      for r in ROS):
            out.append('%s imports %s (only the shell may)' % (package,
                                                               other))
        rank = rank_of(other)
        if rank is not None and rank > rank_of(name):
            out.append('%s imports %s, a layer above it' % (package, other))
    return out


def graph():
    """Module -> the package's modules it imports (a package import
    stands for its ``__init__``)."""
    names = {module_name(p): p for p in modules()}
    edges = {}
    for name, path in names.items():
        edges[name] = set()
        for other in imports(path):
            while other and other not in names:
                init = other + '.__init__'
                other = init if init in names else other.rpartition('.')[0]
            if other and other != name:
                edges[name].add(other)
    return edges


def circle(edges):
    """One import circle of ``edges`` as a list of modules, or []."""
    state = {}

    def visit(node, trail):
        state[node] = 'open'
        for nxt in sorted(edges[node]):
            if state.get(nxt) == 'open':
                return trail[trail.index(nxt):] + [nxt]
            if nxt not in state:
                found = visit(nxt, trail + [nxt])
                if found:
                    return found
        state[node] = 'done'
        return []

    for node in sorted(edges):
        if node not in state:
            found = visit(node, [node])
            if found:
                return found
    return []


def test_every_subpackage_has_a_layer():
    packages = {os.path.basename(os.path.dirname(p)) for p in modules()}
    assert packages == set(RANK)


@pytest.mark.parametrize('path', modules(),
                         ids=lambda p: os.path.relpath(p, SRC))
def test_imports_follow_the_layers(path):
    assert violations(path) == []


def test_no_import_circle():
    assert circle(graph()) == []


def test_the_circle_check_finds_one():
    edges = {'a': {'b'}, 'b': {'c'}, 'c': {'a'}, 'd': {'a'}}
    assert circle(edges) == ['a', 'b', 'c', 'a']
    assert circle({'a': {'b'}, 'b': set()}) == []


def test_the_rule_catches_an_upward_import(tmp_path, monkeypatch):
    wire = tmp_path / 'wire'
    wire.mkdir()
    bad = wire / 'bad.py'
    bad.write_text('import math\nfrom hri_sync.robot import dj_rob\n'
                   'def f():\n    import rospy\n'
                   'from .times import GlobalTime\n'
                   'from hri_sync.clock.ros_clock_state import x\n')
    shell = wire / 'ros_ok.py'
    shell.write_text('import rospy\nfrom hri_sync.ros import params\n')
    monkeypatch.setattr(__import__(__name__), 'SRC', str(tmp_path))
    assert sorted(violations(str(bad))) == [
        'wire imports hri_sync.clock.ros_clock_state, a layer above it',
        'wire imports hri_sync.robot, a layer above it',
        'wire imports rospy (only the shell may)']
    assert violations(str(shell)) == []
