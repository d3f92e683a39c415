"""The control module's check that the recorder is connected before round 1
(hri_sync.ros.recorder_link): from the master's graph and the publishers'
getBusInfo, served here by real XML-RPC servers."""
import threading
from xmlrpc.server import SimpleXMLRPCServer

import pytest

from hri_sync.ros.recorder_link import RecorderLink, unlinked

REC = '/lab/recorder'
LEFT, RIGHT, CM = '/lab/left/dpm', '/lab/right/dpm', '/lab/control_module'
STATE = [
    [['/lab/left/captured', [LEFT]], ['/lab/right/captured', [RIGHT]],
     ['/lab/capture_data', [CM]], ['/lab/not_recorded', [LEFT]],
     ['/lab/recorder/status', [REC]]],
    [['/lab/left/captured', [REC]], ['/lab/right/captured', [REC, '/x']],
     ['/lab/capture_data', [REC]], ['/lab/odom', [REC]],
     ['/lab/not_recorded', ['/x']], ['/lab/recorder/status', [REC]]],
    []]


def row(topic, peer=REC, direction='o', connected=True):
    return [1, peer, direction, 'TCPROS', topic, connected]


def test_every_publisher_of_a_recorded_topic_is_needed():
    assert unlinked(REC, STATE, lambda node: None) == [
        ('/lab/capture_data', CM), ('/lab/left/captured', LEFT),
        ('/lab/right/captured', RIGHT)]


def test_only_a_publishers_connection_to_the_recorder_counts():
    info = {LEFT: [row('/lab/left/captured'), row('/lab/not_recorded')],
            CM: [row('/lab/capture_data')],
            RIGHT: [row('/lab/right/captured', peer='/x'),
                    row('/lab/right/captured', direction='i'),
                    row('/lab/right/captured', connected=False),
                    row('/lab/left/captured'),
                    [1, REC, 'o']]}                 # malformed: ignored
    asked = []

    def bus_info_of(node):
        asked.append(node)
        return info[node]
    assert unlinked(REC, STATE, bus_info_of) == [
        ('/lab/right/captured', RIGHT)]
    assert sorted(asked) == [CM, LEFT, RIGHT]      # each node once
    info[RIGHT].append(row('/lab/right/captured'))
    assert unlinked(REC, STATE, info.get) == []


def master(uris, state):
    """A master's ``call(method, *args)`` (as master_watch.master_call)."""
    def call(method, *args):
        if method == 'lookupNode':
            return (1, '', uris[args[0]]) if args[0] in uris else \
                (-1, 'unknown node [%s]' % args[0], '')
        assert method == 'getSystemState'
        return 1, '', state
    return call


@pytest.fixture
def nodes():
    """XML-RPC APIs of the publishers answering getBusInfo with
    ``rows[node]``; yields (uris, rows)."""
    rows, uris, servers = {}, {REC: 'http://127.0.0.1:1/'}, []
    for node in (LEFT, RIGHT, CM):
        server = SimpleXMLRPCServer(('127.0.0.1', 0), logRequests=False)
        rows[node] = []
        server.register_function(
            lambda caller, node=node: [1, 'bus info', rows[node]],
            'getBusInfo')
        threading.Thread(target=server.serve_forever, daemon=True).start()
        servers.append(server)
        uris[node] = 'http://127.0.0.1:%d/' % server.server_address[1]
    yield uris, rows
    for server in servers:
        server.shutdown()
        server.server_close()


def link(uris):
    return RecorderLink(REC, master(uris, STATE), CM, timeout=2.0)


def test_missing_names_what_is_not_connected(nodes):
    uris, rows = nodes
    checker = link(uris)
    rows[LEFT].append(row('/lab/left/captured'))
    rows[CM].append(row('/lab/capture_data'))
    assert checker.missing() == ('no connection to the recorder %s: '
                                 '/lab/right/captured from %s' % (REC, RIGHT))
    rows[RIGHT].append(row('/lab/right/captured'))
    assert checker.missing() == ''


def test_a_publisher_that_does_not_answer_is_not_connected(nodes):
    uris, rows = nodes
    rows[LEFT].append(row('/lab/left/captured'))
    rows[RIGHT].append(row('/lab/right/captured'))
    uris[CM] = 'http://127.0.0.1:1/'
    gap = 'no connection to the recorder %s: /lab/capture_data from %s' % (
        REC, CM)
    assert link(uris).missing() == gap
    del uris[CM]                  # gone from the master since its state
    assert link(uris).missing() == gap


def test_an_unregistered_recorder_and_an_unreachable_master_are_said():
    assert link({}).missing() == 'the recorder %s is not registered' % REC

    def down(method, *args):
        raise OSError('%s: connection refused' % method)
    assert RecorderLink(REC, down, CM).missing() == (
        'the master cannot be reached (lookupNode: connection refused)')
