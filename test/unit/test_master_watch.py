"""hri_sync.ros.master_watch.MasterWatch: telling a restart from an outage."""

from hri_sync.ros.master_watch import MasterWatch

URI = 'http://host:40001/'


class FakeMaster:
    """A master that knows some nodes, may be down, has a pid."""

    def __init__(self):
        self.nodes = {}
        self.up = True
        self.pid_ = 100

    def lookup(self, name):
        if not self.up:
            raise ConnectionRefusedError(111, 'Connection refused')
        return self.nodes.get(name)

    def pid(self):
        if not self.up:
            raise ConnectionRefusedError(111, 'Connection refused')
        return self.pid_

    def restart(self):
        self.nodes, self.pid_ = {}, self.pid_ + 1


def watch(master):
    return MasterWatch('/control_module', URI, 'http://host:11311/',
                       master.lookup, master.pid)


def test_waits_until_the_node_is_registered():
    m = FakeMaster()
    w = watch(m)
    assert w.check() == 'waiting'     # rospy registers a moment later
    assert w.check() == 'waiting'
    m.nodes['/control_module'] = URI
    assert w.check() == 'ok'
    assert w.check() == 'ok' and not w.restarted


def test_a_restarted_master_is_told_with_its_pids():
    m = FakeMaster()
    w = watch(m)
    m.nodes['/control_module'] = URI
    assert w.check() == 'ok'
    m.up = False
    assert w.check() == 'unreachable'
    assert 'Connection refused' in w.unreachable
    assert w.check() == 'still_unreachable'
    m.up = True
    m.restart()
    assert w.check() == 'restarted'
    assert w.restarted
    assert w.reason == (
        'the ROS master at http://host:11311/ restarted (pid 101, was 100) '
        'and no longer knows /control_module at http://host:40001/: its '
        'topics, services and params are gone')
    assert w.check() == 'restarted'   # for good


def test_a_master_that_only_stops_answering_is_waited_for():
    m = FakeMaster()
    w = watch(m)
    m.nodes['/control_module'] = URI
    w.check()
    m.up = False
    assert w.check() == 'unreachable'
    m.up = True
    assert w.check() == 'back'
    assert w.check() == 'ok' and not w.restarted


def test_lost_registration_on_the_same_master():
    m = FakeMaster()
    w = watch(m)
    m.nodes['/control_module'] = URI
    w.check()
    m.nodes['/control_module'] = 'http://other:40002/'
    assert w.check() == 'restarted'
    assert w.reason == (
        'the ROS master at http://host:11311/ lost its registrations and '
        'no longer knows /control_module at http://host:40001/ (it has '
        'http://other:40002/ under that name): its topics, services and '
        'params are gone')


def test_an_unknown_node_before_its_registration_is_not_a_restart():
    m = FakeMaster()
    w = watch(m)
    m.restart()
    assert w.check() == 'waiting' and not w.restarted


def test_a_restart_before_the_node_was_seen_registered_is_one():
    # Under make test-load the master was killed after the node had
    # registered but before its watch had seen it: it waited for ever.
    m = FakeMaster()
    w = watch(m)
    assert w.check() == 'waiting'
    m.restart()
    assert w.check() == 'restarted'
    assert w.reason.startswith('the ROS master at http://host:11311/ '
                               'restarted (pid 101, was 100)')


def test_a_new_master_that_knows_the_node_again_is_a_restart():
    # The link checks registered a subscription with the new master before
    # the watch asked: the node looked registered, at its URI, for good.
    m = FakeMaster()
    w = watch(m)
    m.nodes['/control_module'] = URI
    assert w.check() == 'ok'
    m.restart()
    m.nodes['/control_module'] = URI
    assert w.check() == 'restarted'
    assert w.reason == (
        'the ROS master at http://host:11311/ restarted (pid 101, was 100) '
        'and no longer knows /control_module at http://host:40001/ (but for '
        'a subscription the link checks registered since): its topics, '
        'services and params are gone')


def test_a_node_watched_from_outside_adopts_its_first_uri():
    m = FakeMaster()
    w = MasterWatch('/recorder', None, 'http://host:11311/', m.lookup, m.pid)
    assert w.check() == 'waiting'
    m.nodes['/recorder'] = URI
    assert w.check() == 'ok' and w.uri == URI
    m.restart()
    assert w.check() == 'restarted'
