"""The Foxglove and PlotJuggler layouts of a session's MCAP (no ROS).

One list of plots (``plots``) makes both layouts, so they always show the
same series: the clients' clock offsets and uncertainties, each
participant's first-frame offset and timing bound, and the scores, every
one against its message's ``header.stamp`` (global time), never the
receipt time. The ``/viewers/...`` topics are the channels
``mcap_export`` derives. ``scripts/make_viewer_layouts.py`` writes them
(``config/layouts/`` holds those of the default dance-off: clients left,
right, server, dj_rob, music; participants left, right).
"""
import json
import os
from xml.sax.saxutils import quoteattr

from hri_sync.tools.mcap_export import VIEWERS

CLOCKS = ('left', 'right', 'server', 'dj_rob', 'music')
PARTICIPANTS = ('left', 'right')
COLORS = ('#1f77b4', '#d62728', '#1ac938', '#ff7f0e', '#9467bd',
          '#8c564b', '#e377c2', '#17becf')


def plots(clocks=CLOCKS, participants=PARTICIPANTS):
    """[(title, [(topic, field path, label)])]: the layouts' plots."""
    def clock(field):
        return [('%s/%s/clock' % (VIEWERS, c), field, c) for c in clocks]

    def result(field, what):
        return [('%s/%s/client_result' % (VIEWERS, p), field,
                 '%s %s' % (p, what)) for p in participants]
    return [
        ('Clock offset, global minus local (s)', clock('offset')),
        ('Clock uncertainty and result timing bound (s)',
         clock('uncertainty') + result('timing_uncertainty', 'bound')),
        ('First-frame offset from the window start (s)',
         result('first_frame_offset', 'first frame')),
        ('Scores: results and decision',
         result('value', 'result') + [
             ('/decision', 'scores[%d]' % i, 'decision %s' % p)
             for i, p in enumerate(participants)]),
    ]


def foxglove(spec):
    """A Foxglove layout (import it: Layouts, Import from file) of
    ``spec`` (``plots()``): a 2x2 grid of Plot panels."""
    config, ids = {}, []
    for n, (title, series) in enumerate(spec):
        pid = 'Plot!hrisync%d' % n
        ids.append(pid)
        config[pid] = {
            'title': title,
            'paths': [{'value': '%s.%s' % (topic, path), 'enabled': True,
                       'label': label, 'color': COLORS[i % len(COLORS)],
                       'timestampMethod': 'headerStamp'}
                      for i, (topic, path, label) in enumerate(series)],
            'showXAxisLabels': True, 'showYAxisLabels': True,
            'showLegend': True, 'legendDisplay': 'floating',
            'showPlotValuesInLegend': False, 'isSynced': True,
            'xAxisVal': 'timestamp', 'sidebarDimension': 240}

    def split(items, direction):
        if len(items) == 1:
            return items[0]
        half = (len(items) + 1) // 2
        return {'direction': direction,
                'first': split(items[:half], direction),
                'second': split(items[half:], direction),
                'splitPercentage': 100.0 * half / len(items)}
    rows = [split(ids[i:i + 2], 'row') for i in range(0, len(ids), 2)]
    layout = {'configById': config, 'globalVariables': {}, 'userNodes': {},
              'playbackConfig': {'speed': 1}, 'layout': split(rows, 'column')}
    return json.dumps(layout, indent=2, sort_keys=True) + '\n'


def plotjuggler(spec, datafile=None, topics=()):
    """A PlotJuggler layout (File, Load layout) of ``spec``: one tab, the
    plots stacked. With ``datafile`` (an MCAP, relative to the layout's
    folder) the layout also loads it, with ``topics`` selected and the
    loader set to the messages' header stamps ("Use the timestamp in the
    message"); without, PlotJuggler asks (tick that box)."""
    areas = []
    for title, series in spec:
        curves = ''.join(
            '       <curve name=%s color="%s"/>\n'
            % (quoteattr('%s/%s' % (topic, path.replace('.', '/'))),
               COLORS[i % len(COLORS)])
            for i, (topic, path, _label) in enumerate(series))
        areas.append(
            '     <DockArea name=%s>\n'
            '      <plot style="Lines" flip_y="false" flip_x="false" '
            'mode="TimeSeries">\n'
            '       <range top="1" bottom="0" left="0" right="1"/>\n'
            '       <limitY/>\n%s      </plot>\n     </DockArea>\n'
            % (quoteattr(title), curves))
    sizes = ';'.join(['%.6f' % (1.0 / len(spec))] * len(spec))
    data = ''
    if datafile:
        data = (
            ' <previouslyLoaded_Datafiles>\n'
            '  <fileInfo filename=%s prefix="">\n'
            '   <plugin ID="DataLoad MCAP">\n'
            '    <parameters use_timestamp="1" use_mcap_log_time="1" '
            'clamp_large_arrays="1" max_array_size="500" '
            'selected_topics=%s/>\n'
            '   </plugin>\n  </fileInfo>\n </previouslyLoaded_Datafiles>\n'
            % (quoteattr(datafile), quoteattr(';'.join(topics))))
    return (
        "<?xml version='1.0' encoding='UTF-8'?>\n<root>\n"
        ' <tabbed_widget name="Main Window" parent="main_window">\n'
        '  <Tab tab_name="hri_sync" containers="1">\n   <Container>\n'
        '    <DockSplitter orientation="-" count="%d" sizes="%s">\n%s'
        '    </DockSplitter>\n   </Container>\n  </Tab>\n'
        '  <currentTabIndex index="0"/>\n </tabbed_widget>\n'
        ' <use_relative_time_offset enabled="1"/>\n%s</root>\n'
        % (len(spec), sizes, ''.join(areas), data))


def write_session(export):
    """Beside an exported MCAP ``X.mcap`` (an ``McapExport``), its own
    layouts for the clients it holds: ``X.plotjuggler.xml`` (which loads
    X.mcap by header stamps) and ``X.foxglove.json``; returns their
    paths."""
    spec = plots(export.clocks, export.participants)
    base = export.path[:-len('.mcap')]
    out = (base + '.plotjuggler.xml', base + '.foxglove.json')
    texts = (plotjuggler(spec, os.path.basename(export.path),
                         export.topics), foxglove(spec))
    for path, text in zip(out, texts):
        with open(path, 'w') as f:
            f.write(text)
    return out
