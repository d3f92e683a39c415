"""hri_sync.data_process.processors: the CountMean processor and
load_processor."""

import math
import textwrap
from types import SimpleNamespace as NS

import pytest

from hri_sync.data_process.processors import (CountMean, Frame, ProcessResult,
                                              Processor, WindowRun,
                                              load_processor)


def frames(*values):
    return [Frame(100.0 + 0.05 * k, NS(value=v)) for k, v in
            enumerate(values)]


def test_count_mean():
    r = CountMean().process(frames(1.0, 2.0, 4.5), 100.0, 101.0)
    assert r == ProcessResult(value=2.5, frames_used=3, frames_rejected=0,
                              diagnostics={'count': 3})


def test_count_mean_rejects_non_finite_values():
    r = CountMean().process(frames(1.0, math.nan, 3.0, math.inf, -math.inf),
                            100.0, 101.0)
    assert (r.value, r.frames_used, r.frames_rejected) == (2.0, 2, 3)
    assert r.diagnostics == {'count': 2}


def test_count_mean_of_no_frames_is_nan():
    r = CountMean().process([], 100.0, 101.0)
    assert math.isnan(r.value)
    assert (r.frames_used, r.frames_rejected) == (0, 0)


def test_base_processor_defaults():
    p = Processor()
    assert p.msg_type == 'hri_sync/Sample'
    assert p.device_stamp(NS(value=1.0)) is None
    with pytest.raises(NotImplementedError):
        p.process([], 0.0, 1.0)


def test_load_processor_by_class_path():
    p = load_processor('hri_sync.data_process.processors.CountMean')
    assert type(p) is CountMean
    assert type(load_processor('hri_sync.data_process.processors.CountMean',
                               {})) is CountMean


@pytest.mark.parametrize('path, message', [
    ('CountMean', "unknown processor 'CountMean': valid: .*"
     "hri_sync.sensors.generic.HeaderCount.*; did you mean "
     "'hri_sync.data_process.processors.CountMean'"),
    ('hri_sync.sensor.imu.ImuActivity', "did you mean "
     "'hri_sync.sensors.imu.ImuActivity'"),
    ('hri_sync.no_such_module.Thing',
     r"unknown processor 'hri_sync.no_such_module.Thing': valid: "),
    ('hri_sync.data_process.processors.CountMaen',
     r"unknown processor in hri_sync.data_process.processors 'CountMaen': "
     r"valid: CountMean, DeviceStampedCountMean; did you mean 'CountMean'"),
    ('hri_sync.data_process.processors.Frame',
     r"processor in hri_sync.data_process.processors 'Frame': valid: "),
    ('math.pi', r"unknown processor in math 'pi': valid: \(none\)$"),
])
def test_load_processor_errors_list_the_valid_names(path, message):
    with pytest.raises(ValueError, match=message):
        load_processor(path)


def test_a_misspelt_key_names_the_valid_keys_and_the_nearest():
    with pytest.raises(ValueError, match=r"~processor_params: unknown key of "
                       r"HeaderCount 'msg_typ': valid: msg_type; did you "
                       r"mean 'msg_type'\?$"):
        load_processor('hri_sync.sensors.generic.HeaderCount',
                       {'msg_typ': 'sensor_msgs/LaserScan'})


def test_processor_without_params_refuses_params():
    with pytest.raises(ValueError, match='CountMean takes no parameters, got '
                       'gain, offset'):
        load_processor('hri_sync.data_process.processors.CountMean',
                       {'offset': 1, 'gain': 2})


@pytest.fixture
def plugin(tmp_path, monkeypatch):
    (tmp_path / 'my_plugin.py').write_text(textwrap.dedent('''
        from hri_sync.data_process.processors import Processor, ProcessResult

        class Scaled(Processor):
            msg_type = 'std_msgs/Float64'

            def __init__(self, gain=1.0):
                self.gain = gain

            def device_stamp(self, msg):
                return msg.t

            def process(self, frames, start, end):
                return ProcessResult(self.gain * len(frames), len(frames))
    '''))
    monkeypatch.syspath_prepend(str(tmp_path))
    yield 'my_plugin.Scaled'


def test_load_a_plugin_with_params(plugin):
    p = load_processor(plugin, {'gain': 2.5})
    assert p.gain == 2.5 and p.msg_type == 'std_msgs/Float64'
    assert p.device_stamp(NS(t=3.25)) == 3.25
    assert p.process(frames(1.0, 2.0), 100.0, 101.0).value == 5.0


def test_plugin_params_that_do_not_fit(plugin):
    with pytest.raises(ValueError, match=r"~processor_params: unknown key "
                       r"of Scaled 'gian': valid: gain; did you mean "
                       r"'gain'"):
        load_processor(plugin, {'gian': 2.5})


def test_device_stamped_count_mean_reads_the_header_stamp():
    p = load_processor(
        'hri_sync.data_process.processors.DeviceStampedCountMean')
    msg = NS(value=2.0, header=NS(stamp=NS(to_sec=lambda: 1234.5)))
    assert p.device_stamp(msg) == 1234.5
    assert p.process(frames(1.0, 3.0), 100.0, 101.0).value == 2.0


# -- the incremental interface -----------------------------------------------

def test_count_mean_added_one_frame_at_a_time():
    p = CountMean()
    p.begin(100.0, 101.0)
    for f in frames(1.0, math.nan, 4.0):
        p.add(f)
    assert p.result() == ProcessResult(value=2.5, frames_used=2,
                                       frames_rejected=1,
                                       diagnostics={'count': 2})
    p.begin(101.0, 102.0)                 # a new window starts from zero
    p.add(frames(7.0)[0])
    assert p.result().value == 7.0


def test_a_whole_window_processor_runs_through_add_and_result(plugin):
    # The default add keeps the frames and result hands them to process.
    p = load_processor(plugin, {'gain': 2.0})
    run = WindowRun(p, 100.0, 101.0)
    for f in frames(1.0, 2.0, 3.0):
        assert run.add(f)
    assert run.result() == ProcessResult(6.0, 3)


def test_process_sorts_the_frames_and_counts_what_add_raised_on():
    seen = []

    class Strict(Processor):
        def begin(self, start, end):
            self.n = 0

        def add(self, frame):
            if frame.msg.value < 0:
                raise ValueError('negative sample %g' % frame.msg.value)
            seen.append(frame.stamp)
            self.n += 1

        def result(self):
            return ProcessResult(float(self.n), self.n)
    fs = frames(1.0, -1.0, 2.0, -3.0)[::-1] + [Frame(math.nan, NS(value=1))]
    r = Strict().process(fs, 100.0, 101.0)
    assert seen == [100.0, 100.1] + [seen[-1]] and math.isnan(seen[-1])
    assert (r.value, r.frames_used, r.frames_rejected) == (3.0, 3, 2)
    assert r.diagnostics == {'processor_errors': 2,
                             'processor_error':
                             "ValueError('negative sample -1')"}


def test_a_processor_with_add_but_no_result_is_refused():
    class Half(Processor):
        def add(self, frame):
            pass
    with pytest.raises(NotImplementedError, match='Half implements neither'):
        Half().process(frames(1.0), 100.0, 101.0)
