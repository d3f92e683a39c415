"""hri_sync.client_process.ros_cpm without a ROS master: the protocol topics
are subscribed by ``start()`` alone, once the node is whole (a capture
order that came while a node was still being built ran its callback on a
half-made node: the music player's ``self.cpm`` did not exist yet)."""
import importlib
import sys
import types

import pytest


def stand_in_messages():
    """hri_sync.msg where it is not built (``make unit`` does not source
    the workspace): a class of each name asked for."""
    module = types.ModuleType('hri_sync.msg')
    classes = {}

    def message(name):
        if name.startswith('__'):
            raise AttributeError(name)
        return classes.setdefault(name, type(name, (), {}))
    module.__getattr__ = message
    return module


@pytest.fixture
def client_process(monkeypatch):
    """client_process with its ROS pieces replaced by recorders."""
    try:
        importlib.import_module('hri_sync.msg')
    except ImportError:
        monkeypatch.setitem(sys.modules, 'hri_sync.msg', stand_in_messages())
    cp = importlib.import_module('hri_sync.client_process.ros_cpm')
    monkeypatch.setattr(cp, 'param', lambda name, default, *a: default)
    monkeypatch.setattr(cp, 'protocol_topic', lambda name: '/' + name)
    monkeypatch.setattr(cp, 'Publisher',
                        lambda *a, **k: types.SimpleNamespace())
    monkeypatch.setattr(
        cp, 'SyncedClock',
        lambda name: types.SimpleNamespace(clock=types.SimpleNamespace(
            ready=False, now=lambda: 0.0)))
    monkeypatch.setattr(cp, 'round_diagnostics',
                        lambda *a: FakeDiagnostics())
    return cp


class FakeInbox:
    """Records subscriptions instead of making them."""

    def __init__(self):
        self.topics = []

    def subscribe(self, topic, msg_class, callback, sender, **kwargs):
        self.topics.append((topic, msg_class, sender))

    def summary(self):
        return {}


class FakeDiagnostics:
    """Takes the CPM's statuses and publishes nothing."""

    def add(self, name, check):
        pass

    def rejections(self, *sources):
        pass


def test_nothing_is_subscribed_before_start(client_process):
    inbox = FakeInbox()
    cpm = client_process.ClientProcess('left', lambda order: None,
                                       inbox=inbox)
    assert inbox.topics == []
    cpm.start()
    assert [(t, c.__name__, s) for t, c, s in inbox.topics] == [
        ('/sync_time', 'SyncTime', 'cm'),
        ('/capture_data', 'CaptureData', 'cm')]
