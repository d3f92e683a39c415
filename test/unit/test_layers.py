"""The layer order of src/hri_sync (docs/architecture.md, "Layers"), from
the imports: a layer imports only itself and the layers below it, and only
``hri_sync.ros`` imports ROS (rospy, the generated messages, ...).

    timing  <  dance_off, people, sensors  <  robot  <  tools  <  ros

``timing`` imports nothing of the package; ``people`` (skeletons of
several people, other trackers' formats), ``sensors`` (stock processors
of standard sensor messages) and ``dance_off`` share a layer.
"""
import ast
import glob
import os

import pytest

SRC = os.path.join(os.path.dirname(__file__), '..', '..', 'src', 'hri_sync')
RANK = {'timing': 0, 'dance_off': 1, 'people': 1, 'sensors': 1, 'robot': 2,
        'tools': 3, 'ros': 4}
ROS = ('rospy', 'rosbag', 'roslib', 'rosgraph', 'genpy', 'rostopic',
       'hri_sync.msg', 'hri_sync.srv', 'std_msgs', 'sensor_msgs',
       'geometry_msgs', 'diagnostic_msgs', 'tf2_ros')


def imports(path):
    """Every module name ``path`` imports (at any depth, lazily too)."""
    with open(path) as f:
        tree = ast.parse(f.read())
    package = os.path.relpath(os.path.dirname(path), SRC).split(os.sep)[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:          # relative: within its own package
                yield 'hri_sync.%s.%s' % (package, node.module or '')
            else:
                yield node.module


def modules():
    return sorted(glob.glob(os.path.join(SRC, '*', '*.py')))


def layer_of(name):
    parts = name.split('.')
    return parts[1] if parts[0] == 'hri_sync' and len(parts) > 1 else None


def violations(path):
    package = os.path.relpath(path, SRC).split(os.sep)[0]
    out = []
    for name in imports(path):
        if package != 'ros' and any(name == r or name.startswith(r + '.')
                                    for r in ROS):
            out.append('%s imports %s (only hri_sync.ros may)' % (package,
                                                                  name))
        other = layer_of(name)
        if other in RANK and RANK[other] > RANK[package]:
            out.append('%s imports %s, a layer above it' % (package, name))
    return out


def test_every_subpackage_has_a_layer():
    packages = {os.path.basename(os.path.dirname(p)) for p in modules()}
    assert packages == set(RANK)


@pytest.mark.parametrize('path', modules(),
                         ids=lambda p: os.path.relpath(p, SRC))
def test_imports_follow_the_layers(path):
    assert violations(path) == []


def test_the_rule_catches_an_upward_import(tmp_path, monkeypatch):
    timing = tmp_path / 'timing'
    timing.mkdir()
    bad = timing / 'bad.py'
    bad.write_text('import math\nfrom hri_sync.robot import dj_rob\n'
                   'def f():\n    import rospy\n'
                   'from .clock import ClockModel\n')
    monkeypatch.setattr(__import__(__name__), 'SRC', str(tmp_path))
    assert violations(str(bad)) == [
        'timing imports hri_sync.robot, a layer above it',
        'timing imports rospy (only hri_sync.ros may)']
