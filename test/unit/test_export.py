"""hri_sync.tools.export.resample: one joint coordinate onto a grid."""
import numpy as np

from hri_sync.tools.export import resample


def test_interpolates_between_usable_neighbours_only():
    stamps = np.array([0.0, 0.05, 0.10, 0.15, 0.40, 0.45])
    values = np.array([0.0, 1.0, 2.0, 3.0, 8.0, 9.0])
    valid = np.array([True, True, False, True, True, True])
    grid = np.array([-0.01, 0.0, 0.025, 0.075, 0.125, 0.3, 0.425, 0.46])
    got = resample(stamps, values, valid, grid, max_gap=0.125)
    # 0.075 and 0.125 lie between 0.05 and 0.15 (the invalid 0.10 is
    # skipped: a 0.1 s gap, allowed); 0.3 lies in a 0.25 s gap: empty;
    # outside the samples: empty.
    want = [np.nan, 0.0, 0.5, 1.5, 2.5, np.nan, 8.5, np.nan]
    np.testing.assert_allclose(got, want)


def test_nothing_usable():
    got = resample(np.array([0.0, 1.0]), np.array([1.0, 2.0]),
                   np.array([False, False]), np.array([0.5]), 1.0)
    assert np.isnan(got).all()
