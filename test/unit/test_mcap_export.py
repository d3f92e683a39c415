"""``report --export mcap`` (hri_sync.tools.mcap_export, layouts): the MCAP
opened with the mcap library matches the bag (topics, counts, bytes,
header stamps), the derived channels carry the right stamps, the layouts
name only series the MCAP has, and an interrupted write (a full disk, a
kill) leaves the bag whole, no MCAP under its final name, and says so."""
import errno
import hashlib
import json
import math
import os
import signal
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest
from mcap.reader import make_reader
from rosbags.rosbag1 import Reader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from hri_sync.tools import layouts, mcap_export
from hri_sync.tools.mcap_export import McapError, write_mcap
from hri_sync_support.harness import run_script

ROOT = os.path.join(os.path.dirname(__file__), '..', '..')
BAGS = os.path.join(ROOT, 'test', 'bags')
SESSION = os.path.join(BAGS, 'session_still.bag')
REPORT = os.path.join(ROOT, 'nodes', 'report')
OLD = os.path.join(BAGS, 'session_robot.bag')   # before std_msgs/Header


def sha(path):
    with open(path, 'rb') as f:
        return hashlib.sha256(f.read()).hexdigest()


def bag_messages(path):
    """[(topic, type, t_ns, raw)] of a bag, in time order."""
    with Reader(path) as r:
        return [('/' + c.topic.lstrip('/'), c.msgtype.replace('/msg/', '/'),
                 t, raw) for c, t, raw in r.messages()]


def mcap_messages(path):
    """[(topic, schema name, schema data, encodings, log time, data)]."""
    with open(path, 'rb') as f:
        return [(ch.topic, s.name, s.data.decode(), (s.encoding,
                 ch.message_encoding), m.log_time, m.data)
                for s, ch, m in make_reader(f).iter_messages(
                    log_time_order=True)]


class Decoder:
    """ROS 1 messages decoded with the definitions the MCAP carries."""

    def __init__(self):
        self.store = get_typestore(Stores.ROS1_NOETIC)
        self.known = set()

    def __call__(self, name, definition, data):
        kind = name.replace('/', '/msg/', 1)
        if kind not in self.known:
            self.store.register(get_types_from_msg(definition, kind))
            self.known.add(kind)
        return self.store.deserialize_ros1(data, kind)


@pytest.fixture(scope='module')
def exported(tmp_path_factory):
    out = str(tmp_path_factory.mktemp('mcap') / 'session.mcap')
    return write_mcap(SESSION, out), out


@pytest.mark.parametrize('bag', ['session_robot.bag', 'rounds_pilot.bag',
                                 'session_still.bag'])
def test_the_mcap_holds_every_bag_message_as_recorded(bag, tmp_path):
    path = os.path.join(BAGS, bag)
    before = sha(path)
    done = write_mcap(path, str(tmp_path / 'x.mcap'))
    recorded = bag_messages(path)
    written = [m for m in mcap_messages(done.path)
               if not m[0].startswith('/viewers/')]
    assert done.messages == len(recorded) == len(written)
    counts = {}
    for (topic, kind, t, raw), (mtopic, name, _d, enc, log, data) in zip(
            recorded, written):
        assert (mtopic, name, log, data) == (topic, kind, t, raw)
        assert enc == ('ros1msg', 'ros1')
        counts[topic] = counts.get(topic, 0) + 1
    assert sorted(counts) == sorted({m[0] for m in recorded})
    assert sha(path) == before
    assert not os.path.exists(done.path + mcap_export.PART)


def test_header_stamps_decoded_from_the_mcap_match_the_bag(exported):
    done, path = exported
    decode, stamps_bag, stamps_mcap = Decoder(), [], []
    with Reader(SESSION) as r:
        store = get_typestore(Stores.ROS1_NOETIC)
        seen = set()
        for c, _t, raw in r.messages():
            if c.msgtype not in seen:
                store.register(get_types_from_msg(c.msgdef.data, c.msgtype))
                seen.add(c.msgtype)
            msg = store.deserialize_ros1(raw, c.msgtype)
            if hasattr(msg, 'header'):
                h = msg.header.stamp
                stamps_bag.append(('/' + c.topic.lstrip('/'), h.sec,
                                   h.nanosec))
    for topic, name, definition, _e, _t, data in mcap_messages(path):
        msg = decode(name, definition, data)
        if not topic.startswith('/viewers/') and hasattr(msg, 'header'):
            h = msg.header.stamp
            stamps_mcap.append((topic, h.sec, h.nanosec))
    assert len(stamps_bag) > 700
    assert stamps_mcap == stamps_bag


def test_derived_clock_stamps_are_the_global_time_of_local_ref(exported):
    done, path = exported
    decode = Decoder()
    states, derived = {}, {}
    for topic, name, definition, _e, log, data in mcap_messages(path):
        if topic.endswith('/clock_state'):
            states.setdefault(topic.split('/')[1], []).append(
                (log, decode(name, definition, data)))
        elif topic.startswith('/viewers/') and topic.endswith('/clock'):
            assert name == mcap_export.CLOCK_TYPE
            derived.setdefault(topic.split('/')[2], []).append(
                (log, decode(name, definition, data)))
    assert sorted(derived) == sorted(states) == sorted(done.clocks)
    for client, msgs in states.items():
        ok = [(t, m) for t, m in msgs if m.ok]
        assert len(derived[client]) == len(ok) > 0
        for (t, m), (dt, d) in zip(ok, derived[client]):
            stamp = d.header.stamp.sec + d.header.stamp.nanosec * 1e-9
            assert dt == t
            assert stamp == pytest.approx(m.local_ref + m.offset, abs=2e-9)
            assert (d.offset, d.uncertainty, d.client_id) == (
                m.offset, m.uncertainty, m.client_id)


def test_results_are_split_per_client_with_their_own_stamps(exported):
    done, path = exported
    decode = Decoder()
    results = [(decode(n, d, b).client_id, b) for t, n, d, _e, _l, b
               in mcap_messages(path) if t == '/client_result']
    for client in ('left', 'right'):
        mine = [b for t, n, d, _e, _l, b in mcap_messages(path)
                if t == '/viewers/%s/client_result' % client]
        assert mine == [b for c, b in results if c == client]
        assert len(mine) == 1
    assert done.participants == ['left', 'right']


def test_results_recorded_without_a_header_are_counted_not_derived(
        tmp_path):
    done = write_mcap(OLD, str(tmp_path / 'old.mcap'))
    assert done.skipped == {'result recorded without a header': 4}
    assert not [t for t in done.derived if t.endswith('client_result')]
    assert '4 result recorded without a header' in mcap_export.summary(done)


def test_a_clock_state_without_a_model_is_not_derived_and_counted():
    class State:
        ok, local_ref, offset, client_id = False, 0.0, math.nan, 'left'
        drift, uncertainty, samples, round_trip = 0.0, math.inf, 0, math.nan
    assert mcap_export.clock_stamped(State(), 0) is None
    State.ok, State.local_ref, State.offset = True, 100.25, 2.5
    data = mcap_export.clock_stamped(State(), 7)
    assert data[:12] == bytes.fromhex('07000000') + (102).to_bytes(
        4, 'little') + (750000000).to_bytes(4, 'little')


def test_layouts_plot_only_series_the_mcap_has_against_header_stamps(
        exported):
    done, path = exported
    fields = {}
    decode = Decoder()
    for topic, name, definition, _e, _l, data in mcap_messages(path):
        fields.setdefault(topic, decode(name, definition, data))
    pj_path, fox_path = layouts.write_session(done)
    fox = json.load(open(fox_path))
    paths = [p for c in fox['configById'].values() for p in c['paths']]
    assert len(paths) >= 12
    for p in paths:
        assert p['timestampMethod'] == 'headerStamp'
        topic, _, field = p['value'].partition('.')
        msg = fields[topic]
        name, _, index = field.partition('[')
        value = getattr(msg, name)
        if index:
            value = value[int(index.rstrip(']'))]
        assert isinstance(value, float), p['value']
        assert hasattr(msg, 'header'), topic
    root = ET.parse(pj_path).getroot()
    curves = [c.get('name') for c in root.iter('curve')]
    assert len(curves) == len(paths)
    params = root.find('previouslyLoaded_Datafiles/fileInfo/plugin/'
                       'parameters')
    assert params.get('use_timestamp') == '1'
    assert set(params.get('selected_topics').split(';')) == set(fields)
    for curve in curves:
        assert any(curve.startswith(t + '/') for t in fields), curve


def test_shipped_layouts_are_the_generated_ones():
    spec = layouts.plots()
    folder = os.path.join(ROOT, 'config', 'layouts')
    with open(os.path.join(folder, 'hri_sync.foxglove.json')) as f:
        assert f.read() == layouts.foxglove(spec)
    with open(os.path.join(folder, 'hri_sync.plotjuggler.xml')) as f:
        text = f.read()
    assert text == layouts.plotjuggler(spec)
    ET.fromstring(text)


def no_space():
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))


def killed():
    os.kill(os.getpid(), signal.SIGKILL)


class FullDisk:
    """A file that calls ``full()`` (fails like a full disk, or is killed)
    at the first write after ``budget`` bytes."""

    def __init__(self, path, mode, budget, full=no_space):
        self.f = open(path, mode)
        self.budget, self.full = budget, full

    def write(self, data):
        if self.budget < len(data):
            self.f.flush()
            self.full()
        self.budget -= len(data)
        return self.f.write(data)

    def __getattr__(self, name):
        return getattr(self.f, name)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.f.close()


def test_a_full_disk_removes_the_part_keeps_the_old_mcap_and_the_bag(
        tmp_path):
    dst = str(tmp_path / 'session.mcap')
    before = sha(SESSION)
    write_mcap(SESSION, dst)
    good = sha(dst)
    with pytest.raises(McapError) as e:
        write_mcap(SESSION, dst, lambda p, m: FullDisk(p, m, 50000))
    text = str(e.value)
    assert 'No space left on device' in text
    assert 'Removed the partial' in text and 'kept' in text
    assert sha(dst) == good
    assert not os.path.exists(dst + mcap_export.PART)
    assert sha(SESSION) == before


def test_a_failed_first_export_leaves_no_mcap(tmp_path):
    dst = str(tmp_path / 'session.mcap')
    with pytest.raises(McapError, match='after [0-9]+ of the bag'):
        write_mcap(SESSION, dst, lambda p, m: FullDisk(p, m, 100))
    assert os.listdir(str(tmp_path)) == []


KILLER = '''
import sys
sys.path[:0] = [%r, %r, %r]
from hri_sync.tools.mcap_export import write_mcap
from test_mcap_export import FullDisk, killed
# killed at the first write past 1000 bytes (after the first chunk)
write_mcap(%r, %r, lambda p, m: FullDisk(p, m, 1000, killed))
'''


def test_a_killed_export_leaves_only_a_part_file_and_is_replaced(tmp_path):
    dst = str(tmp_path / 'session.mcap')
    before = sha(SESSION)
    p = subprocess.run([sys.executable, '-c', KILLER % (
        os.path.join(ROOT, 'src'), os.path.join(ROOT, 'support'),
        os.path.dirname(os.path.abspath(__file__)), SESSION, dst)],
        timeout=600)
    assert p.returncode == -signal.SIGKILL
    assert not os.path.exists(dst)
    assert os.path.getsize(dst + mcap_export.PART) > 0
    assert sha(SESSION) == before
    done = write_mcap(SESSION, dst)
    assert done.replaced_part
    assert 'interrupted export' in mcap_export.summary(done)
    assert not os.path.exists(dst + mcap_export.PART)
    assert len(mcap_messages(dst)) == done.messages + sum(
        done.derived.values())


def test_report_cli_writes_the_mcap_and_layouts(tmp_path):
    out = str(tmp_path)
    code, text = run_script(REPORT, [
        SESSION, '--out', os.path.join(out, 'r'), '--export', 'mcap',
        '--mcap-dir', out])
    assert code == 0, text
    assert 'MCAP: 1241 messages' in text
    assert sorted(os.listdir(out)) == [
        'r', 'session_still.foxglove.json', 'session_still.mcap',
        'session_still.plotjuggler.xml']


def test_report_cli_says_when_the_mcap_cannot_be_written(tmp_path):
    code, text = run_script(REPORT, [
        SESSION, '--out', str(tmp_path / 'r'), '--export', 'mcap',
        '--mcap-dir', str(tmp_path / 'no' / 'such')])
    assert code == 2
    assert 'MCAP of %s not written' % SESSION in text
    assert 'No such file or directory' in text
