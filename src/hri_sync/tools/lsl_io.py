"""pylsl, as hri_sync's LSL inlet, outlet and benchmark use it (docs/lsl.md).

No ROS.  pylsl (PyPI; it bundles liblsl) is in the package's venv:
the nodes that import this call ``hri_sync.tools.venv.ensure(['pylsl'],
...)`` first.
"""
import ctypes
import time

import pylsl
import pylsl.lib
import pylsl.util


def wall_minus_lsl(tries=3):
    """This process's wall clock (time.time) minus its LSL clock
    (local_clock), from the closest of ``tries`` back-to-back reads (each
    to within the microseconds between its two wall reads)."""
    best = None
    for _ in range(tries):
        a = time.time()
        lsl = pylsl.local_clock()
        b = time.time()
        if best is None or b - a < best[0]:
            best = (b - a, (a + b) / 2 - lsl)
    return best[1]


def time_correction_ex(inlet, timeout=2.0):
    """LSL's clock offset to ``inlet``'s outlet: (correction, remote LSL
    time of the estimate, its round-trip time), from liblsl's
    lsl_time_correction_ex (pylsl gives only the correction).  Raises
    pylsl's TimeoutError or LostError as time_correction does."""
    lib = pylsl.lib.lib
    remote = ctypes.c_double()
    rtt = ctypes.c_double()
    err = ctypes.c_int()
    fn = lib.lsl_time_correction_ex
    fn.restype = ctypes.c_double
    fn.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_double),
                   ctypes.POINTER(ctypes.c_double), ctypes.c_double,
                   ctypes.POINTER(ctypes.c_int)]
    correction = fn(inlet.obj, ctypes.byref(remote), ctypes.byref(rtt),
                    timeout, ctypes.byref(err))
    pylsl.util.handle_error(err)
    return correction, remote.value, rtt.value


def resolve(name='', kind='', source_id='', timeout=1.0):
    """The StreamInfos of the streams matching every given property
    (name, type, source_id), waiting up to ``timeout`` s."""
    terms = ["%s='%s'" % (k, v.replace("'", '')) for k, v in (
        ('name', name), ('type', kind), ('source_id', source_id)) if v]
    if not terms:
        raise ValueError('give a stream name, type or source_id')
    return pylsl.resolve_bypred(' and '.join(terms), 1, timeout)


def describe(info):
    """One line naming a StreamInfo's stream."""
    return ('%s (type %s, %d channels of %s at %g Hz, source_id %r, '
            'host %s)') % (
        info.name(), info.type(), info.channel_count(),
        'string' if info.channel_format() == pylsl.cf_string
        else 'numbers', info.nominal_srate(), info.source_id(),
        info.hostname())
