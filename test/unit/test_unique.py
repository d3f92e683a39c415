"""hri_sync.ros.unique: a node refuses a name a live node holds."""
import pytest

from hri_sync.ros import unique


@pytest.mark.parametrize('argv, env, expected', [
    ([], {}, '/control_module'),
    (['__ns:=/lab1'], {}, '/lab1/control_module'),
    ([], {'ROS_NAMESPACE': '/lab1/left'}, '/lab1/left/control_module'),
    (['__name:=cpm'], {'ROS_NAMESPACE': '/lab1/left/'}, '/lab1/left/cpm'),
    (['__ns:=/lab2', '__name:=dm'], {'ROS_NAMESPACE': '/lab1'},
     '/lab2/dm'),
    (['__name:=/abs'], {'ROS_NAMESPACE': '/lab1'}, '/abs'),
])
def test_resolved_node_name(argv, env, expected):
    assert unique.resolved_node_name('control_module', argv, env) == \
        expected


def test_a_live_node_is_a_duplicate():
    uris = {'/lab1/control_module': 'http://h:1/'}
    assert unique.live_duplicate('/lab1/control_module', uris.get,
                                 lambda uri: 42) == ('http://h:1/', 42)


def test_a_free_name_or_a_dead_node_is_not():
    uris = {'/lab1/control_module': 'http://h:1/'}
    assert unique.live_duplicate('/lab2/control_module', uris.get,
                                 lambda uri: 42) is None
    # registered, but nothing answers at its URI: ROS takes it over
    assert unique.live_duplicate('/lab1/control_module', uris.get,
                                 lambda uri: None) is None


def test_message_names_the_system_and_the_node():
    text = unique.message('/lab1/control_module', 'http://h:1/', 42)
    assert text.startswith('a system already runs in /lab1/: node '
                           '/lab1/control_module is alive (pid 42')
    assert 'use another namespace' in text
    # a client's node: its system is the parent namespace
    assert 'runs in /lab1/: node /lab1/left/cpm' in unique.message(
        '/lab1/left/cpm', 'http://h:2/', 7, client_id='left')
