"""The report's plots, drawn from the summary dict only (matplotlib, Agg).

Each function takes the parts of ``hri_sync.tools.analysis.summarize``'s
output it shows and returns a PNG as bytes, so everything plotted is in
``summary.json``. None (JSON null) values are gaps.
"""
import io
import math

import matplotlib
matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402

DPI = 80
COLORS = plt.rcParams['axes.prop_cycle'].by_key()['color']


def _num(values):
    return [math.nan if v is None else v for v in values]


def _figure(rows, cols, width, height, hspace=0.12, wspace=0.3, left=0.8,
            **kw):
    """A figure with fixed margins (``left`` in left, 0.55 in below): no
    layout pass, which would cost a third of the drawing time."""
    fig, axes = plt.subplots(rows, cols, figsize=(width, height), **kw)
    fig.subplots_adjust(left=left / width, right=1 - 0.15 / width,
                        bottom=0.55 / height, top=1 - 0.5 / height,
                        hspace=hspace, wspace=wspace)
    return fig, axes


def _png(fig):
    buf = io.BytesIO()
    fig.savefig(buf, format='png', dpi=DPI)
    plt.close(fig)
    return buf.getvalue()


def _windows(ax, rounds, t0):
    for r in rounds:
        if r.get('start') is not None and r.get('dur') is not None:
            ax.axvspan(r['start'] - t0, r['start'] - t0 + r['dur'],
                       color='0.9', zorder=0)


def clocks(series, rounds, t0):
    """Each client's clock model over the session: offset change since
    its first measurement, drift, uncertainty and NTP round trip."""
    # Room for a y label beside tick labels like -0.00125.
    fig, axes = _figure(2, 2, 12, 5.5, wspace=0.32, left=1.1, sharex=True)
    panels = [('offset_ms', 'offset change since first [ms]', True),
              ('drift_ppm', 'drift [ppm]', False),
              ('uncertainty_ms', 'offset uncertainty [ms]', False),
              ('round_trip_ms', 'NTP round trip [ms]', False)]
    for ax, (key, label, relative) in zip(axes.flat, panels):
        _windows(ax, rounds, t0)
        for i, (client, s) in enumerate(sorted(series.items())):
            y = _num(s[key])
            if relative:
                first = next((v for v in y if math.isfinite(v)), math.nan)
                y = [v - first for v in y]
            ax.plot(_num(s['t']), y, '.-', ms=3, lw=1,
                    color=COLORS[i % len(COLORS)], label=client)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel('global time since the first round opened [s] '
                      '(grey: capture windows)')
    axes[0][0].legend(fontsize=8, ncol=3)
    fig.suptitle('Clock models (each ClockState a client published)')
    return _png(fig)


def rounds_overview(rounds):
    """Per round: start skew, error bound, first-frame offsets, ACK round
    time and decision latency."""
    fig, axes = _figure(1, 3, 12, 3.2)
    n = [r['round'] for r in rounds]
    ax = axes[0]
    ax.plot(n, _num([r.get('start_skew_ms') for r in rounds]), 'o-',
            label='start skew (true time)')
    ax.plot(n, _num([r.get('error_bound_ms') for r in rounds]), 's--',
            label='error bound')
    ax.set_ylabel('ms')
    ax.set_title('start skew and error bound')
    ax.legend(fontsize=8)
    ax = axes[1]
    clients = sorted({c for r in rounds for c in r.get('clients', {})})
    for i, c in enumerate(clients):
        ax.plot(n, _num([r['clients'].get(c, {}).get('first_frame_offset_ms')
                         for r in rounds]), 'o', color=COLORS[i % 10],
                label=c)
    ax.set_ylabel('ms after the window start')
    ax.set_title('first frame in the window')
    if clients:
        ax.legend(fontsize=8)
    ax = axes[2]
    ax.plot(n, _num([r.get('ack_round_ms') for r in rounds]), 'o-',
            label='ACK round (SyncTime to CaptureData)')
    ax.plot(n, _num([r.get('decision', {}).get('latency_ms')
                     for r in rounds]), 's--',
            label='decision after the window end')
    ax.set_ylabel('ms')
    ax.set_title('round timing')
    ax.legend(fontsize=8)
    for ax in axes:
        ax.set_xlabel('round')
        ax.grid(alpha=0.3)
    return _png(fig)


def session_heading(heading, rounds, t0, bearings):
    """DJ Rob's heading over the whole session."""
    fig, ax = _figure(1, 1, 12, 2.8)
    _windows(ax, rounds, t0)
    ax.plot(_num(heading['t']), _num(heading['deg']), lw=1, color='k',
            label='heading (odometry)')
    for i, b in enumerate(bearings):
        ax.axhline(b, color=COLORS[i % 10], ls='--', lw=1,
                   label='participant %d at %+.0f deg' % (i + 1, b))
    ax.set_xlabel('global time since the first round opened [s] '
                  '(grey: capture windows)')
    ax.set_ylabel('deg')
    ax.legend(fontsize=8, loc='upper right')
    ax.grid(alpha=0.3)
    ax.set_title('DJ Rob over the session')
    return _png(fig)


def round_figure(r, min_expressiveness):
    """One round: Figure 5 (frame ticks against the window start), each
    score building up, and DJ Rob's heading."""
    robot = r.get('robot')
    panels = 3 if robot and robot.get('heading', {}).get('t') else 2
    fig, axes = _figure(1, panels, 4.2 * panels, 3.0)
    ax = axes[0]
    clients = sorted(set(r.get('fig5', {})) | set(r.get('fig5_raw', {})))
    for i, c in enumerate(clients):
        color = COLORS[i % 10]
        raw = _num(r.get('fig5_raw', {}).get(c, []))
        if raw:
            ax.plot(raw, [i] * len(raw), '|', ms=14, color=color,
                    alpha=0.35)
        ticks = _num(r.get('fig5', {}).get(c, []))
        ax.plot(ticks, [i] * len(ticks), '|', ms=18, mew=2, color=color)
        if ticks:
            ax.annotate('%.1f ms' % ticks[0], (ticks[0], i + 0.25),
                        fontsize=8, color=color)
    ax.axvline(0.0, color='k', lw=1.5)
    ax.set_yticks(range(len(clients)))
    ax.set_yticklabels(clients)
    ax.set_ylim(-0.7, len(clients) - 0.3)
    ax.set_xlim(-200, 400)
    ax.set_xlabel('ms from the window start (global)')
    ax.set_title('frames around the start (Fig. 5)', fontsize=10)
    ax.grid(alpha=0.3, axis='x')
    ax = axes[1]
    for i, (c, curve) in enumerate(sorted(r.get('build_up', {}).items())):
        ax.plot(_num(curve['t']), _num(curve['value']), lw=1.5,
                color=COLORS[i % 10], label=c)
    if min_expressiveness is not None:
        ax.axhline(min_expressiveness, color='0.5', ls=':', lw=1,
                   label='min_expressiveness')
    ax.set_xlabel('s into the window')
    ax.set_ylabel('expressiveness [m²/s²]')
    ax.set_title('scores building up', fontsize=10)
    ax.grid(alpha=0.3)
    if r.get('build_up'):
        ax.legend(fontsize=8)
    if panels == 3:
        ax = axes[2]
        h = robot['heading']
        if r.get('dur') is not None:
            ax.axvspan(0.0, r['dur'], color='0.9', zorder=0)
        ax.plot(_num(h['t']), _num(h['deg']), lw=1.2, color='k',
                label='heading')
        for i, b in enumerate(robot.get('bearings_deg', [])):
            ax.axhline(b, color=COLORS[i % 10], ls='--', lw=1,
                       label='participant %d' % (i + 1))
        if robot.get('decision_t') is not None:
            ax.axvline(robot['decision_t'], color='r', lw=1,
                       label='decision')
        if robot.get('gesture_start') is not None:
            ax.axvline(robot['gesture_start'], color='g', lw=1, ls='-.',
                       label='gesture starts')
        ax.set_xlabel('s from the window start (grey: window)')
        ax.set_ylabel('deg')
        ax.set_title('DJ Rob heading', fontsize=10)
        ax.legend(fontsize=7, loc='lower left')
        ax.grid(alpha=0.3)
    fig.suptitle('round %d' % r['round'], fontsize=11)
    return _png(fig)
