"""hri_sync.tools.plots: the report's figures keep their labels whole."""
import pytest

pytest.importorskip('matplotlib', reason='python3-matplotlib (make setup)')

from hri_sync.tools import plots  # noqa: E402


def test_the_clock_figure_keeps_its_y_labels_whole(monkeypatch):
    figs = []
    monkeypatch.setattr(plots, '_png', figs.append)
    t = [0.0, 1.0, 2.0]
    plots.clocks({'eeg': {'t': t, 'offset_ms': [0.0, -0.00125, 0.00075],
                          'drift_ppm': [-12.3456, -3.25, 1.5],
                          'uncertainty_ms': [0.00125, 0.0021, 0.0035],
                          'round_trip_ms': [0.55, 0.6125, 0.7]}}, [], 0.0)
    fig = figs[0]
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    for ax in fig.axes:
        label = ax.yaxis.label.get_window_extent(r)
        assert label.x0 >= 0, ax.get_ylabel()
        for other in fig.axes:
            box = other.get_window_extent(r)
            if other is not ax and box.x1 < label.x1:
                assert label.x0 > box.x1, ax.get_ylabel()
