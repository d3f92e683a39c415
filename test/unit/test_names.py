"""hri_sync.ros.names: the system namespace and names resolved in it."""
import pytest

from hri_sync.ros.names import resolve_in, system_namespace_of


@pytest.mark.parametrize('namespace, client, expected', [
    ('/', None, '/'),
    ('/', 'left', '/'),
    ('/left/', 'left', '/'),
    ('/lab1/', None, '/lab1/'),
    ('/lab1/left/', 'left', '/lab1/'),
    ('/lab1/left', 'left', '/lab1/'),
    # a whole-client node (turtlebot_gesture as dj_rob) is in NS itself
    ('/lab1/', 'dj_rob', '/lab1/'),
    ('/site/lab1/right/', 'right', '/site/lab1/'),
    # a client node in a namespace not its own: that namespace is NS
    ('/lab1/other/', 'left', '/lab1/other/'),
])
def test_system_namespace_of(namespace, client, expected):
    assert system_namespace_of(namespace, client) == expected


def test_resolve_in_the_system_namespace():
    assert resolve_in('/lab1/', 'sync_time', '/lab1/left/', {}) == \
        '/lab1/sync_time'
    assert resolve_in('/', 'left/clock_state', '/', {}) == \
        '/left/clock_state'


def test_a_remapping_as_written_on_the_node_wins():
    # sync_time:=/other/sync on a node in /lab1/left/
    maps = {'/lab1/left/sync_time': '/other/sync'}
    assert resolve_in('/lab1/', 'sync_time', '/lab1/left/', maps) == \
        '/other/sync'


def test_a_remapping_of_the_resolved_name_applies():
    maps = {'/lab1/decision': '/lab1/decision_relayed'}
    assert resolve_in('/lab1/', 'decision', '/lab1/left/', maps) == \
        '/lab1/decision_relayed'
    # a client's own topic, remapped as the node sees it
    maps = {'/lab1/left/clock_state': '/lab1/left/clock_fixed'}
    assert resolve_in('/lab1/', 'left/clock_state', '/lab1/left/',
                      maps) == '/lab1/left/clock_fixed'


@pytest.mark.parametrize('name', ['/sync_time', '~sync_time'])
def test_resolve_in_needs_a_relative_name(name):
    with pytest.raises(ValueError, match='relative'):
        resolve_in('/lab1/', name, '/lab1/', {})
