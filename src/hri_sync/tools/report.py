"""``report BAG... --out DIR``: the session report (no ROS).

Reads each recording (``hri_sync.tools.bag``), sorts it into rounds
(``session``), computes every figure (``analysis``), draws the plots
(``plots``) and writes ``DIR/index.html`` (``page``: self-contained,
plots embedded) and ``DIR/summary.json`` (every figure shown, for
scripts); with ``export`` also the aligned CSV (``export``); with
``write_mcaps`` each bag as MCAP for Foxglove and PlotJuggler
(``mcap_export``).
"""
import json
import os
import time

from hri_sync.tools import (analysis, bag, export, layouts, mcap_export,
                            page, plots)
from hri_sync.tools.session import build_session


def _figures(s):
    """Draw the session's plots: (figure entries, {id: png})."""
    figures, images = [], {}
    key = s['anchor']

    def add(fig_id, title, kind, png, rnd=None):
        figures.append({'id': fig_id, 'title': title, 'kind': kind,
                        'round': rnd})
        images[fig_id] = png

    rounds = s['rounds']
    if s['clocks']:
        add(key + '-clocks', 'Clocks: offset, drift, uncertainty and NTP '
            'round trips', 'clocks', plots.clocks(s['clocks'], rounds,
                                                  s['t0']))
    if rounds:
        add(key + '-rounds', 'Rounds: start skew, error bound, first '
            'frames, ACK round and decision latency', 'rounds',
            plots.rounds_overview(rounds))
    if s.get('heading'):
        add(key + '-heading', 'DJ Rob: heading over the session',
            'heading', plots.session_heading(
                s['heading'], rounds, s['t0'],
                rounds[0].get('robot', {}).get('bearings_deg', [])
                if rounds else []))
    threshold = s['decision_rule'].get('min_expressiveness')
    for r in rounds:
        if r.get('start') is None:
            continue
        fig_id = '%s-round%d' % (key, r['round'])
        r['figure'] = fig_id
        add(fig_id, 'Round %d' % r['round'], 'round',
            plots.round_figure(r, threshold), r['round'])
    return figures, images


def build(paths, out_dir, allow_old=False, do_reindex=False,
          rule=None, tolerance=10.0, export_csv=False, rate=30.0,
          say=print):
    """Write the report of ``paths`` into ``out_dir``; returns the report
    dict. A bag that cannot be read is listed under 'errors' (and the
    rest rendered); if none can be read, raises bag.BagError."""
    report = {'generated': time.strftime('%Y-%m-%d %H:%M:%S %Z'),
              'sessions': [], 'errors': []}
    images = {}
    contents = []
    for group in bag.split_groups(paths):
        try:
            contents.append(bag.open_session(group, allow_old, do_reindex,
                                             say))
        except bag.BagError as e:
            report['errors'].append(str(e))
    if not contents:
        raise bag.BagError('; '.join(report['errors']))
    for i, c in enumerate(contents):
        session = build_session(c)
        s = analysis.clean(analysis.summarize(session, rule, tolerance))
        s['anchor'] = 's%d' % (i + 1)
        for r in s['rounds']:
            r['anchor'] = '%s-r%d' % (s['anchor'], r['round'])
        s['figures'], imgs = _figures(s)
        images.update(imgs)
        report['sessions'].append(s)
        if export_csv:
            s['export'] = export.write_csv(session, out_dir, rate,
                                           s['anchor'] if len(contents) > 1
                                           else '')
    os.makedirs(out_dir, exist_ok=True)
    with open(os.path.join(out_dir, 'index.html'), 'w') as f:
        f.write(page.render(report, images))
    with open(os.path.join(out_dir, 'summary.json'), 'w') as f:
        json.dump(report, f, indent=1, allow_nan=False)
    return report


def write_mcaps(paths, mcap_dir=None, say=print):
    """``report --export mcap``: each bag of ``paths`` as MCAP beside it
    (or in ``mcap_dir``), with its PlotJuggler and Foxglove layouts; a bag
    that ``--reindex`` salvaged is read from its reindexed copy. Says what
    each wrote; returns the errors."""
    errors = []
    for path in paths:
        active = bag.unclosed(path)
        if active and os.path.exists(bag.reindexed_path(active)):
            path = bag.reindexed_path(active)
        try:
            done = mcap_export.write_mcap(
                path, mcap_export.mcap_path(path, mcap_dir))
        except (bag.BagError, mcap_export.McapError) as e:
            errors.append('MCAP of %s not written: %s' % (path, e))
            continue
        say('%s: MCAP: %s; layouts %s' % (
            path, mcap_export.summary(done),
            ', '.join(layouts.write_session(done))))
    return errors


def one_line(report):
    """Rounds, decisions reproduced, robot correct, start skew p99, error
    bound p99 over every session of ``report``."""
    rounds = [r for s in report['sessions'] for r in s['rounds']]
    t = analysis.totals(rounds)

    def p99(d):
        return 'n/a' if d['p99'] is None else '%.3f ms' % d['p99']
    return ('%d rounds (%d decided%s): %s, robot '
            'correct in %d/%d, start skew p99 %s, error bound p99 %s'
            % (t['rounds'], t['decided'],
               ', cut off: %s' % t['cut_off'] if t['cut_off'] else '',
               analysis.reproduced_text(t), t['robot_ok'],
               t['robot_checked'], p99(analysis.clean(t['start_skew_ms'])),
               p99(analysis.clean(t['error_bound_ms']))))
