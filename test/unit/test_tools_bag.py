"""hri_sync.tools.bag: reading recordings, and what goes wrong with them."""
import os
import shutil

import pytest

pytest.importorskip('rosbags', reason='rosbags is installed by make venv')

from rosbags.rosbag1 import Reader, Writer  # noqa: E402

import bag_edit  # noqa: E402
from hri_sync.tools import bag  # noqa: E402
from hri_sync.tools.session import build_session  # noqa: E402

BAGS = os.path.join(os.path.dirname(__file__), '..', 'bags')
SESSION = os.path.join(BAGS, 'session_robot.bag')


def capture_time(path, round_n):
    """Bag time (ns) of round ``round_n``'s /capture_data."""
    with Reader(path) as r:
        conns = [c for c in r.connections if c.topic == '/capture_data']
        times = [t for _, t, _ in r.messages(conns)]
    return times[round_n - 1]


def test_a_definition_only_appended_to_is_read_as_it_is():
    still = os.path.join(BAGS, 'session_still.bag')
    with Reader(still) as r:
        digests = {c.msgtype.replace('/msg/', '/'): c.digest
                   for c in r.connections}
    ours = bag.current_md5sums()
    for kind, md5s in bag.APPENDED.items():
        assert digests[kind] == md5s[0] and ours[kind] not in md5s, kind
    c = bag.read_bag(still)
    assert not c.old_types
    start = c.messages['/dj_rob/action_start'][0].msg
    assert start.action == 'dance' and not hasattr(start, 'status')


def test_a_result_recorded_before_noise_source_is_read(tmp_path):
    # ClientResult without its last field (noise_source) and its NOISE_
    # constants: the definition before them, whose md5 APPENDED lists last.
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    with open(os.path.join(bag.msg_dir(), 'ClientResult.msg')) as f:
        text = f.read()
    assert text.rstrip().endswith('string noise_source')
    before = '\n'.join(line for line in text.rstrip().splitlines()[:-1]
                       if not line.startswith('string NOISE_'))
    store = get_typestore(Stores.ROS1_NOETIC)
    store.register(get_types_from_msg(before, 'hri_sync/msg/ClientResult'))
    msgdef, md5 = store.generate_msgdef('hri_sync/msg/ClientResult',
                                        ros_version=1)
    assert md5 == bag.APPENDED['hri_sync/ClientResult'][-1]
    fields = bag_edit.appended(store, 'hri_sync/msg/ClientResult', {})
    stamp = store.types['builtin_interfaces/msg/Time'](5, 0)
    fields.update(round=1, client_id='left', status='ok', value=2.0,
                  noise_floor=0.3, header=store.types['std_msgs/msg/Header'](
                      seq=0, stamp=stamp, frame_id=''))
    path = tmp_path / 'before.bag'
    with Writer(path) as w:
        conn = w.add_connection('/client_result', 'hri_sync/msg/ClientResult',
                                msgdef=msgdef, md5sum=md5)
        w.write(conn, 10 ** 9, store.serialize_ros1(
            store.types['hri_sync/msg/ClientResult'](**fields),
            'hri_sync/msg/ClientResult'))
    c = bag.read_bag(str(path))
    assert not c.old_types
    r = build_session(c).rounds[1].results['left'].msg
    assert r.noise_floor == 0.3 and not hasattr(r, 'noise_source')


def test_session_bag_reads_whole():
    c = bag.read_bag(SESSION)
    assert not c.old_types
    for topic in ('/odom', '/mobile_base/commands/velocity',
                  '/dj_rob/action_start', '/music/action_start',
                  '/round_status', '/left/clock_state', '/server/clock_state',
                  '/left/capture_command', '/mobile_base/commands/led1'):
        assert c.messages.get(topic), topic
    s = build_session(c)
    assert sorted(s.rounds) == [1, 2] and not s.cut_off
    assert s.config['participant_bearings'] == [30.0, -30.0]
    assert set(s.clock_states) == {'left', 'right', 'dj_rob', 'music',
                                   'server'}


def test_topics_recorded_by_relative_names(tmp_path):
    # rosbag record in a system's namespace records 'decision', not
    # '/lab1/decision': read as '/decision', the session is the same.
    relative = str(tmp_path / 'relative.bag')
    bag_edit.copy_bag(SESSION, relative,
                      rename=lambda t: t if t == '/diagnostics'
                      else t.lstrip('/'))
    with Reader(relative) as r:
        assert 'dance_off/config' in {c.topic for c in r.connections}
    c = bag.read_bag(relative)
    assert c.messages.get('/dance_off/config') and c.messages.get('/odom')
    s, whole = build_session(c), build_session(bag.read_bag(SESSION))
    assert s.config == whole.config and s.config['participant_bearings']
    assert sorted(s.rounds) == sorted(whole.rounds) == [1, 2]
    assert set(s.clock_states) == set(whole.clock_states)


def test_empty_file_and_empty_bag(tmp_path):
    empty = tmp_path / 'empty.bag'
    empty.write_bytes(b'')
    with pytest.raises(bag.BagError, match='empty file'):
        bag.read_bag(str(empty))
    nothing = tmp_path / 'nothing.bag'
    with Writer(nothing):
        pass
    with pytest.raises(bag.BagError, match='holds no messages'):
        bag.read_bag(str(nothing))
    other = tmp_path / 'other.bag'
    other.write_bytes(b'not a bag at all\n')
    with pytest.raises(bag.BagError, match='not a rosbag'):
        bag.read_bag(str(other))


def test_other_message_version_is_named(tmp_path):
    old = str(tmp_path / 'old.bag')
    fake = '0123456789abcdef0123456789abcdef'
    bag_edit.copy_bag(SESSION, old, md5={'hri_sync/ClientResult': fake})
    ours = bag.current_md5sums()['hri_sync/ClientResult']
    with pytest.raises(bag.BagError) as e:
        bag.read_bag(old)
    text = str(e.value)
    assert 'hri_sync/ClientResult' in text and fake in text and ours in text
    assert '--allow-old-messages' in text
    c = bag.read_bag(old, allow_old=True)
    assert c.old_types == {'hri_sync/ClientResult': (fake, ours)}
    assert len(c.messages['/client_result']) == 4


def test_unclosed_bag_says_how_to_reindex(tmp_path):
    active = str(tmp_path / 'cut.bag.active')
    bag_edit.write_unclosed(SESSION, active,
                            capture_time(SESSION, 2) + 10 ** 9)
    for path in (active, str(tmp_path / 'cut.bag')):
        with pytest.raises(bag.BagError) as e:
            bag.read_bag(path)
        assert 'rosbag reindex %s' % active in str(e.value)
        assert '--reindex' in str(e.value)
    said = []
    c = bag.open_bags([str(tmp_path / 'cut.bag')], do_reindex=True,
                      say=said.append)[0]
    assert c.path == str(tmp_path / 'cut.bag')
    assert 'reindexed into' in said[0]
    s = build_session(c)
    assert s.cut_off == [2]               # its window began, no decision
    assert s.rounds[1].decision is not None
    with pytest.raises(bag.BagError, match='exists already'):
        bag.open_bags([active], do_reindex=True, say=said.append)


def test_reindex_a_real_killed_recorder(tmp_path):
    # rosbag record -O k.bag /chatter, killed with SIGKILL after 4 s at
    # 50 Hz: the open chunk was never closed (size 0).
    src = str(tmp_path / 'k.bag.active')
    shutil.copy(os.path.join(BAGS, 'killed_recorder.bag.active'), src)
    assert bag.unclosed(str(tmp_path / 'k.bag')) == src
    salvage = bag.reindex(src, str(tmp_path / 'k.bag'))
    assert salvage.topics == {'/chatter': 205}
    c = bag.read_bag(str(tmp_path / 'k.bag'))
    assert [r.msg.data for r in c.messages['/chatter']][:2] == ['hello'] * 2


def test_reindex_keeps_every_message_before_the_cut(tmp_path):
    cut = capture_time(SESSION, 2)
    active = str(tmp_path / 'x.bag.active')
    bag_edit.write_unclosed(SESSION, active, cut)
    bag.reindex(active, str(tmp_path / 'x.bag'))
    with Reader(SESSION) as a, Reader(str(tmp_path / 'x.bag')) as b:
        before = [(c.topic, t, bytes(raw)) for c, t, raw in a.messages()
                  if t < cut]
        after = [(c.topic, t, bytes(raw)) for c, t, raw in b.messages()]
    assert sorted(before) == sorted(after)


def test_split_groups_puts_the_parts_of_a_recording_together():
    paths = ['d/s_1.bag', 'a.bag', 'd/s_0.bag', 'd/s_10.bag', 'd/s_2.bag',
             'e/s_3.bag']
    assert bag.split_groups(paths) == [
        ['d/s_0.bag', 'd/s_1.bag', 'd/s_2.bag', 'd/s_10.bag'], ['a.bag'],
        ['e/s_3.bag']]
    assert bag.group_label(['a.bag']) == 'a.bag'
    assert '2 split parts' in bag.group_label(['d/s_0.bag', 'd/s_1.bag'])


def split_in_two(tmp_path):
    """session_robot.bag cut as rosbag record --split cuts it: mid-round,
    the latched /dance_off/config in the first part only."""
    with Reader(SESSION) as r:
        cut = capture_time(SESSION, 1) + (r.end_time - capture_time(
            SESSION, 1)) // 2
    parts = [str(tmp_path / 's_0.bag'), str(tmp_path / 's_1.bag')]
    bag_edit.copy_bag(SESSION, parts[0],
                      edit=lambda _topic, t, m: m if t < cut else None)
    bag_edit.copy_bag(SESSION, parts[1],
                      edit=lambda _topic, t, m: m if t >= cut else None)
    return parts


def test_the_parts_of_a_split_recording_are_one_session(tmp_path):
    whole = build_session(bag.read_bag(SESSION))
    parts = split_in_two(tmp_path)
    merged = build_session(bag.open_session(bag.split_groups(parts)[0],
                                            say=lambda *_: None))
    second = build_session(bag.read_bag(parts[1]))
    assert merged.config == whole.config and not second.config
    decided = sorted(n for n, r in whole.rounds.items() if r.decision)
    assert decided and sorted(
        n for n, r in merged.rounds.items() if r.decision) == decided
    assert merged.cut_off == whole.cut_off
    for topic, recs in whole_messages(SESSION).items():
        assert len(bag.open_session(parts, say=lambda *_: None)
                   .messages.get(topic, [])) == recs, topic


def whole_messages(path):
    return {t: len(m) for t, m in bag.read_bag(path).messages.items()}
