"""The report's self-contained HTML page (no ROS, no network).

``render(report, images)`` writes the summary dict of
``hri_sync.tools.report`` as one HTML page; ``images`` maps each figure
id of ``report['figures']`` to PNG bytes, embedded as base64 data URIs,
so the page opens offline.
"""
import base64
import html
import math

from hri_sync.tools.analysis import calibration_text, reproduced_text

CSS = """
body { font-family: sans-serif; margin: 1.5em; color: #222; max-width: 1300px }
h1 { font-size: 1.5em } h2 { font-size: 1.25em; border-bottom: 1px solid #999 }
h3 { font-size: 1.05em; margin-bottom: 0.3em }
table { border-collapse: collapse; margin: 0.4em 0 0.8em; font-size: 0.85em }
th, td { border: 1px solid #ccc; padding: 2px 6px; text-align: right }
th { background: #eee } td.l, th.l { text-align: left }
.ok { color: #080; font-weight: bold } .bad { color: #b00; font-weight: bold }
.na { color: #888 } .verdict { margin: 0.3em 0 }
.missing { background: #fff4e0; border: 1px solid #e0b060; padding: 0.4em }
.error { background: #fde; border: 1px solid #c66; padding: 0.4em }
img { max-width: 100%; display: block; margin: 0.3em 0 }
code { font-size: 0.9em }
"""


def _e(text):
    return html.escape(str(text))


def fmt(v, spec='%.3f', na='n/a'):
    """A number for the page; None/NaN is ``na``."""
    if v is None:
        return '<span class="na">%s</span>' % na
    if isinstance(v, bool):
        return 'yes' if v else 'no'
    if isinstance(v, (int, float)):
        if isinstance(v, float) and not math.isfinite(v):
            return '<span class="na">%s</span>' % na
        return spec % v
    return _e(v)


def _table(head, rows, left=(0,)):
    out = ['<table><tr>']
    out += ['<th%s>%s</th>' % (' class="l"' if i in left else '', _e(h))
            for i, h in enumerate(head)]
    out.append('</tr>')
    for row in rows:
        out.append('<tr>' + ''.join(
            '<td%s>%s</td>' % (' class="l"' if i in left else '', c)
            for i, c in enumerate(row)) + '</tr>')
    out.append('</table>')
    return '\n'.join(out)


def _img(fig_id, images, alt):
    data = base64.b64encode(images[fig_id]).decode('ascii')
    return ('<img id="%s" alt="%s" src="data:image/png;base64,%s">'
            % (_e(fig_id), _e(alt), data))


def _mark(ok, text):
    cls = 'na' if ok is None else ('ok' if ok else 'bad')
    return '<span class="%s">%s</span>' % (cls, _e(text))


def _clock_table(clocks):
    rows = []
    for client, s in sorted(clocks.items()):
        def stats(key):
            vals = [v for v in s[key] if v is not None]
            if not vals:
                return [fmt(None)] * 2
            return [fmt(sorted(vals)[len(vals) // 2]), fmt(max(vals))]
        offs = [v for v in s['offset_ms'] if v is not None]
        drifts = [v for v in s['drift_ppm'] if v is not None]
        rows.append([_e(client), str(len(s['t'])),
                     str(s['ok'].count(False)),
                     fmt(offs[0] if offs else None, '%+.3f'),
                     fmt(offs[-1] if offs else None, '%+.3f'),
                     fmt(drifts[-1] if drifts else None, '%+.2f')]
                    + stats('uncertainty_ms') + stats('round_trip_ms'))
    return _table(['client', 'states', 'failed', 'first offset [ms]',
                   'last offset [ms]', 'last drift [ppm]',
                   'uncertainty p50 [ms]', 'max', 'NTP round trip p50 [ms]',
                   'max'], rows)


def _rounds_table(rounds):
    rows = []
    for r in rounds:
        d = r.get('decision', {})
        rec = r.get('recomputed', {})
        robot = r.get('robot', {})
        rows.append([
            '<a href="#%s">%d</a>' % (_e(r['anchor']), r['round']),
            fmt(r.get('cr_t'), '%.3f'), fmt(r.get('str_aft'), '%.3f'),
            fmt(r.get('dur'), '%.2f'), fmt(r.get('ack_round_ms'), '%.1f'),
            fmt(r.get('start_skew_ms')), fmt(r.get('error_bound_ms')),
            _e(d.get('outcome', 'CUT OFF')) + (
                ' %d' % d['winner'] if d.get('winner') else ''),
            _mark(rec.get('reproduced'), {True: 'yes', False: 'NO'}.get(
                rec.get('reproduced'), 'n/a')),
            _mark(robot.get('ok'), {True: 'yes', False: 'NO'}.get(
                robot.get('ok'), 'n/a')),
            _mark(r['ok'], {True: 'pass', False: 'FAIL'}.get(r['ok'],
                                                             'cut off'))])
    return _table(['round', 'CR_T [s]', 'STR_AFT [s]', 'DUR [s]',
                   'ACK round [ms]', 'start skew [ms]', 'error bound [ms]',
                   'decision', 'reproduced', 'robot', 'verdict'], rows)


def _round_section(r, images, rule):
    # Over 80 lines: the HTML of one round's section, in page order.
    out = ['<h3 id="%s">Round %d</h3>' % (_e(r['anchor']), r['round'])]
    out.append('<p class="verdict">%s</p>' % _mark(r['ok'], r['verdict']))
    if r.get('start') is not None:
        out.append('<p>CR_T %s + STR_AFT %s s, DUR %s s: window [%s, %s) '
                   'global; ACK round %s ms; start skew %s ms (%s); '
                   'error bound %s ms</p>' % (
                       fmt(r['cr_t'], '%.6f'), fmt(r['str_aft'], '%.4f'),
                       fmt(r['dur'], '%.3f'), fmt(r['start'], '%.6f'),
                       fmt(r['start'] + r['dur'], '%.6f'),
                       fmt(r.get('ack_round_ms'), '%.1f'),
                       fmt(r.get('start_skew_ms')),
                       _e(r.get('start_skew_note', '')),
                       fmt(r.get('error_bound_ms'))))
    if r.get('aborted_reason'):
        out.append('<p>Aborted by the CM: %s</p>' % _e(r['aborted_reason']))
    if r.get('acks'):
        out.append(_table(
            ['ACK', 'ok', 'offset [s]', 'uncertainty [ms]', 'drift [ppm]',
             'SyncTime received after [ms]', 'ACK sent after [ms]',
             'reason'],
            [[_e(c), fmt(a['ok']), fmt(a['offset_s'], '%+.6f'),
              fmt(a['uncertainty_ms']), fmt(a['drift_ppm'], '%+.2f'),
              fmt(a['dispatch_ms'], '%.2f'), fmt(a['ack_ms'], '%.1f'),
              _e(a['reason'])] for c, a in sorted(r['acks'].items())],
            left=(0, 7)))
    rec = r.get('recomputed', {})
    values = rec.get('values', {})
    rows = []
    for c in r.get('participants', []):
        v = r['clients'].get(c, {})
        rows.append([_e(c), _e(v.get('status')), fmt(v.get('frames'), '%d'),
                     fmt(v.get('rejected'), '%d'),
                     fmt(v.get('dropped'), '%d'),
                     fmt(v.get('coverage'), '%.3f'),
                     fmt(v.get('first_frame_offset_ms'), '%.1f'),
                     fmt(v.get('wake_lateness_ms'), '%.2f'),
                     fmt(v.get('clock_error_ms')),
                     fmt(v.get('error_bound_ms')),
                     fmt(v.get('value'), '%.6g'),
                     fmt(values.get(c), '%.6g')])
    if rows:
        out.append(_table(
            ['client', 'status', 'frames', 'rejected', 'dropped',
             'coverage', 'first frame [ms]', 'wake late [ms]',
             'clock error [ms]', 'error bound [ms]', 'score',
             'recomputed'], rows, left=(0, 1)))
    d = r.get('decision')
    if d:
        out.append('<p>Decision: <b>%s</b>%s: %s (rule: %s, '
                   'noise_factor %s, min_expressiveness '
                   '%s, tie_margin %s, on_missing %s); decided %s ms after '
                   'the window end</p>' % (
                       _e(d['outcome']),
                       ' participant %d (%s)' % (d['winner'],
                                                 _e(d['winner_client']))
                       if d['winner'] else '', _e(d['reason']),
                       _e(rule.get('decision_rule', 'threshold')),
                       fmt(rule.get('noise_factor'), '%g'),
                       fmt(rule['min_expressiveness'], '%g'),
                       fmt(rule['tie_margin'], '%g'),
                       _e(rule['on_missing']),
                       fmt(d.get('latency_ms'), '%.0f')))
    starts = r.get('starts', {})
    robot = r.get('robot')
    if starts or robot:
        items = ['%s started %s ms from the schedule by its clock (%s ms by '
                 'the host clock)' % (_e(a), fmt(s['offset_ms'], '%+.2f'),
                                      fmt(s['true_offset_ms'], '%+.2f'))
                 for a, s in sorted(starts.items())]
        if robot and robot.get('expected'):
            items.append('after the window: expected to %s; %s' % (
                _e(robot['expected']), _e(robot['verdict'])))
            items.append('final heading %s deg, target %s deg, moved up to '
                         '%s m and %s deg after the window' % (
                             fmt(robot.get('final_heading_deg'), '%+.1f'),
                             fmt(robot.get('target_deg'), '%+.1f'),
                             fmt(robot.get('travel_m'), '%.3f'),
                             fmt(robot.get('turn_deg'), '%.1f')))
            if robot.get('gesture_latency_ms') is not None:
                items.append('gesture: first moving command %s ms after the '
                             'decision was recorded, %s s after the window '
                             'start' % (fmt(robot['gesture_latency_ms'],
                                            '%.0f'),
                                        fmt(robot.get('gesture_start'),
                                            '%.2f')))
        out.append('<p>DJ Rob and the music:</p><ul>%s</ul>' % ''.join(
            '<li>%s</li>' % i for i in items))
    if r.get('duplicates'):
        out.append('<p>Duplicates: %s</p>' % _e('; '.join(r['duplicates'])))
    if r.get('figure'):
        out.append(_img(r['figure'], images, 'round %d' % r['round']))
    return '\n'.join(out)


def _session(s, images):
    out = ['<h2 id="%s">%s</h2>' % (_e(s['anchor']), _e(s['bag']))]
    t = s['totals']
    out.append('<p class="verdict">%s</p>' % _mark(t['ok'], (
        '%d rounds, %d decided (%s), %s, robot correct '
        'in %d of %d checked; start skew p50 %s / p99 %s ms; error bound '
        'p99 %s ms%s' % (
            t['rounds'], t['decided'], ', '.join(
                '%s %d' % kv for kv in sorted(t['outcomes'].items())),
            reproduced_text(t), t['robot_ok'], t['robot_checked'],
            _plain(t['start_skew_ms']['p50']),
            _plain(t['start_skew_ms']['p99']),
            _plain(t['error_bound_ms']['p99']),
            '; cut off by the recording: rounds %s' % ', '.join(
                map(str, t['cut_off'])) if t['cut_off'] else ''))))
    if s['missing']:
        out.append('<div class="missing"><b>Not in this recording</b> '
                   '(those parts of the report are left out):<ul>%s</ul>'
                   '</div>' % ''.join(
                       '<li>%s: %s</li>' % (_e(m['section']),
                                            _e(m['reason']))
                       for m in s['missing']))
    if s['old_types']:
        out.append('<div class="missing">Read with the bag\'s own message '
                   'definitions (--allow-old-messages): %s</div>' % _e(
                       '; '.join('%s (bag md5 %s, package %s)'
                                 % (k, v['bag'], v['package'])
                                 for k, v in sorted(s['old_types'].items()))))
    out.append('<p>%.1f s recorded; decision rule %s; participants\' '
               'bearings %s; times of the robot by %s.</p>' % (
                   s['duration_s'] or 0.0, _e(s['decision_rule']),
                   _e(s['config'].get('participant_bearings', 'n/a')),
                   _e(s['recorder_clock'])))
    for fig in s['figures']:
        if fig.get('round') is None:
            out.append('<h3>%s</h3>' % _e(fig['title']))
            out.append(_img(fig['id'], images, fig['title']))
            if fig['kind'] == 'clocks':
                out.append(_clock_table(s['clocks']))
    if 'calibration' in s:
        out.append('<p>%s</p>' % _e(calibration_text(s['calibration'])))
    if s['rounds']:
        out.append('<h3>Rounds</h3>')
        out.append(_rounds_table(s['rounds']))
    for r in s['rounds']:
        out.append(_round_section(r, images, s['decision_rule']))
    return '\n'.join(out)


def _plain(v):
    return 'n/a' if v is None else '%.3f' % v


def render(report, images):
    """The page for ``report`` (see hri_sync.tools.report.build)."""
    body = ['<h1>hri_sync session report</h1>',
            '<p>%s; generated by <code>report</code> from %d recording(s). '
            'Every figure is also in <code>summary.json</code>.</p>' % (
                _e(report['generated']), len(report['sessions'])
                + len(report['errors']))]
    for e in report['errors']:
        body.append('<div class="error">%s</div>' % _e(e))
    for s in report['sessions']:
        body.append(_session(s, images))
    return ('<!DOCTYPE html>\n<html><head><meta charset="utf-8">'
            '<title>hri_sync session report</title><style>%s</style>'
            '</head><body>\n%s\n</body></html>\n' % (CSS, '\n'.join(body)))
