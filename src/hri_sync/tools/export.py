"""``report --export csv``: captured joints on one global time grid.

For every round with captured skeletons, each participant's joints are
resampled onto one grid of global times (``rate`` Hz from the window
start, within the window), so two people's motion can be compared
sample by sample, and the raw samples are written alongside:

- ``aligned.csv``: round, global time, time into the window, then for
  each client and joint ``<client>_<joint>_x|y|z`` (m, sensor frame),
  linearly interpolated between that joint's two neighbouring usable
  samples (finite, confidence at least the result's ``min_confidence``);
  empty where the client has no usable sample on both sides within
  ``max_gap`` (GAP_PERIODS median frame periods, as a window's coverage);
- ``raw.csv``: every captured frame: round, client, global stamp, time
  into the window, device stamp, and per joint x, y, z and confidence.
"""
import csv
import math
import os

import numpy as np

from hri_sync.dance_off.joints import JOINTS
from hri_sync.data_process.capture import GAP_PERIODS
from hri_sync.tools.analysis import (_min_confidence, _window,
                                     skeleton_arrays)
from hri_sync.tools.session import secs


def resample(stamps, values, valid, grid, max_gap):
    """``values`` (N,) at ``stamps`` (N,), where ``valid``, linearly
    interpolated at ``grid``; NaN outside the usable samples or across a
    gap longer than ``max_gap``."""
    s, v = stamps[valid], values[valid]
    out = np.full(len(grid), np.nan)
    if len(s) == 0:
        return out
    if len(s) == 1:
        out[np.abs(grid - s[0]) < 1e-9] = v[0]
        return out
    hi = np.searchsorted(s, grid, 'left')
    inside = (grid >= s[0]) & (grid <= s[-1])
    lo = np.clip(hi - 1, 0, len(s) - 1)
    hi = np.clip(hi, 0, len(s) - 1)
    exact = s[hi] == grid
    gap = np.where(exact, 0.0, s[hi] - s[lo])
    ok = inside & (gap <= max_gap)
    out[ok] = np.interp(grid[ok], s, v)
    return out


def _header_raw():
    cols = ['round', 'client', 'stamp', 't_window', 'device_stamp']
    for j in JOINTS:
        cols += ['%s_%s' % (j, a) for a in ('x', 'y', 'z', 'confidence')]
    return cols


def _num(v):
    return '' if not math.isfinite(v) else '%.9g' % v


def _stamp_text(v):
    return '' if not math.isfinite(v) else '%.6f' % v


def write_csv(session, out_dir, rate, prefix=''):
    """Write aligned.csv and raw.csv of ``session`` into ``out_dir``
    (names prefixed by ``prefix``-); returns {'aligned', 'raw', 'rows'}."""
    if not rate > 0:
        raise ValueError('--rate must be > 0 Hz, got %r' % rate)
    os.makedirs(out_dir, exist_ok=True)
    name = (prefix + '-') if prefix else ''
    aligned_path = os.path.join(out_dir, name + 'aligned.csv')
    raw_path = os.path.join(out_dir, name + 'raw.csv')
    clients = sorted(session.captured)
    rows = 0
    with open(aligned_path, 'w', newline='') as fa, \
            open(raw_path, 'w', newline='') as fr:
        aligned, raw = csv.writer(fa), csv.writer(fr)
        aligned.writerow(['round', 'stamp', 't_window'] + [
            '%s_%s_%s' % (c, j, a) for c in clients for j in JOINTS
            for a in ('x', 'y', 'z')])
        raw.writerow(_header_raw())
        for n in sorted(session.rounds):
            rnd = session.rounds[n]
            if rnd.capture is None:
                continue
            start, end = rnd.start, rnd.end
            grid = start + np.arange(int(math.ceil(
                (end - start) * rate - 1e-9))) / rate
            grid = grid[grid < end]
            columns = []
            for c in clients:
                frames = _window(session.captured[c], start, end)
                frames = [f for f in frames if hasattr(f[1], 'positions')]
                stamps, pos, conf = skeleton_arrays(frames)
                res = rnd.results.get(c)
                min_conf = _min_confidence(res.msg) if res else 0.0
                for (s, m), p, q in zip(frames, pos, conf):
                    row = [n, c, _stamp_text(s), _num(s - start),
                           _stamp_text(secs(m.device_stamp))
                           if hasattr(m, 'device_stamp') else '']
                    for k in range(len(JOINTS)):
                        row += [_num(p[k][0]), _num(p[k][1]), _num(p[k][2]),
                                _num(q[k])]
                    raw.writerow(row)
                period = float(np.median(np.diff(stamps))) \
                    if len(stamps) > 1 else 0.0
                max_gap = GAP_PERIODS * period
                for k in range(len(JOINTS)):
                    valid = np.all(np.isfinite(pos[:, k, :]), axis=1) & \
                        (conf[:, k] >= min_conf) if len(stamps) else \
                        np.zeros(0, bool)
                    for a in range(3):
                        columns.append(resample(stamps, pos[:, k, a], valid,
                                                grid, max_gap)
                                       if len(stamps) else
                                       np.full(len(grid), np.nan))
            for i, t in enumerate(grid):
                aligned.writerow([n, _stamp_text(t), _num(t - start)]
                                 + [_num(col[i]) for col in columns])
                rows += 1
    return {'aligned': aligned_path, 'raw': raw_path, 'rows': rows,
            'rate_hz': rate}
