"""bench/fusion_noise.py: the figures, their spread and the targets met
over the noise seeds."""
import importlib.util
import os
import subprocess
import sys

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..',
                      '..', 'bench', 'fusion_noise.py')
spec = importlib.util.spec_from_file_location('fusion_noise', SCRIPT)
bench = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bench)


def result(best, fused, best_hidden, fused_hidden, coverage=0.99,
           duplicates=0, latency=99.0, slowest=96.0, paired=None,
           alone=None, nearest=None, later=None):
    """A fusion_accuracy.py JSON result's keys the bench reads
    (``paired``: the best view and the fused body on the same instants,
    and its share of them; ``alone``: the best view alone through the
    fusion, whole and hidden; ``nearest``: the view nearest the truth,
    whole and hidden; ``later``: fused afterwards, the sides in doubt
    put right from later instants, whole and hidden; the run's own
    figures by default)."""
    best_m, fused_m, share = paired or (best, fused, 1.0)
    alone_m, alone_hidden = alone or (best, best_hidden)
    nearest_m, nearest_hidden = nearest or (best, best_hidden)
    later_m, later_hidden = later or (fused, fused_hidden)
    return {'single_view_mean_m': {'front': best, 'right': best + 0.01},
            'best_view': 'front',
            'best_view_alone': {'mean_m': alone_m,
                                'hidden_mean_m': alone_hidden},
            'best_view_instants': {'share': share, 'best_view_m': best_m,
                                   'fused_m': fused_m},
            'fused_mean_m': fused,
            'view_oracle_mean_m': nearest_m,
            'view_oracle_hidden_mean_m': nearest_hidden,
            'best_view_hidden_mean_m': best_hidden,
            'fused_hidden_mean_m': fused_hidden,
            'latency_p95_ms': latency, 'slowest_pipeline_p95_ms': slowest,
            'duplicate_people': duplicates, 'bound_coverage': coverage,
            'bound_median_m': 0.15,
            'labels_from_later': {'fused_mean_m': later_m,
                                  'fused_hidden_mean_m': later_hidden,
                                  'bound_coverage': coverage,
                                  'exchanged_instants': 0}}


def test_seed_one_is_the_scene_as_given():
    assert bench.scene_for('noise=kinect1', 1) == 'noise=kinect1'
    assert bench.scene_for('noise=kinect1', 3) == 'noise=kinect1&seed=3'


def test_figures_are_below_the_best_view_in_percent():
    f = bench.figures(result(0.060, 0.045, 0.160, 0.100, latency=101.0))
    assert f['best_view_m'] == 0.060
    assert f['below_best_pct'] == 25.0
    assert f['hidden_below_best_pct'] == 37.5
    assert f['latency_beyond_slowest_ms'] == 5.0
    assert f['below_best_same_instants_pct'] == 25.0
    assert f['bound_median_m'] == 0.15
    # The best view lost the person for the last third: on its instants
    # the fused body is 20 % below it, over the run 10 % above.
    f = bench.figures(result(0.100, 0.110, 0.2, 0.1,
                             paired=(0.100, 0.080, 0.7)))
    assert f['below_best_pct'] == -10.0
    assert f['below_best_same_instants_pct'] == 20.0
    assert f['best_view_instant_share'] == 0.7
    # Alone through the fusion the best view is 0.05 m, 0.125 on the hidden
    f = bench.figures(result(0.060, 0.045, 0.160, 0.100,
                             alone=(0.050, 0.125)))
    assert f['below_best_alone_pct'] == 10.0
    assert f['hidden_below_best_alone_pct'] == 20.0
    # The view nearest the truth at each joint: 0.054 m, 0.12 hidden.
    f = bench.figures(result(0.060, 0.045, 0.160, 0.100,
                             nearest=(0.054, 0.120)))
    assert f['nearest_view_below_best_pct'] == 10.0
    assert f['nearest_view_hidden_below_best_pct'] == 25.0
    # Fused afterwards, the start's sides put right: 0.042 m, 0.08 hidden.
    f = bench.figures(result(0.060, 0.045, 0.160, 0.100,
                             later=(0.042, 0.080), coverage=0.97))
    assert f['afterwards_below_best_pct'] == 30.0
    assert f['afterwards_hidden_below_best_pct'] == 50.0
    assert f['afterwards_bound_coverage'] == 0.97
    # A view that tracked no one has no error, and is not the best.
    out = result(0.060, 0.045, 0.160, 0.100)
    out['single_view_mean_m']['back'] = None
    assert bench.figures(out)['best_view_m'] == 0.060


def test_targets_are_counted_per_seed_and_spread_summarized():
    results = [result(0.060, 0.045, 0.160, 0.090),     # 25 %, 43.8 %
               result(0.060, 0.050, 0.160, 0.100),     # 16.7 %, 37.5 %
               result(0.060, 0.040, 0.160, 0.080, coverage=0.94)]
    verdicts = [{'fused_20pct_below_best_view': True,
                 'latency_p95_within_134_ms': True,
                 'bound_coverage_95pct': True},
                {'fused_20pct_below_best_view': False,
                 'latency_p95_within_130_ms': True,
                 'bound_coverage_95pct': True},
                {'fused_20pct_below_best_view': True,
                 'latency_p95_within_131_ms': False,
                 'bound_coverage_95pct': False}]
    runs = []
    for seed, (r, v) in enumerate(zip(results, verdicts), start=1):
        r['targets'] = v
        runs.append(dict(seed=seed, targets=bench.verdicts(r),
                         **bench.figures(r)))
    met, applied = bench.targets_met(runs)
    assert met == {'fused_20pct_below_best_view': 2,
                   'latency_p95_within_38_ms_of_slowest_view': 2,
                   'bound_coverage_95pct': 2}
    assert set(applied.values()) == {3}
    s = bench.summary(runs)
    assert 'seed' not in s and 'targets' not in s
    assert s['below_best_pct'] == {'median': 25.0, 'min': 16.7,
                                   'max': 33.3, 'of': 3}
    assert s['bound_coverage']['min'] == 0.94


def test_a_draw_whose_best_view_hides_nothing_has_no_hidden_figures():
    # An upper-body gesture seen whole by the best view in two draws of
    # three: the hidden-joint figures are null there, not NaN, and the
    # summary and the target count only the draw that has them.
    results = [result(0.060, 0.045, None, None),
               result(0.060, 0.045, 0.160, 0.090),
               result(0.060, 0.045, None, None)]
    hidden = [None, True, None]
    runs = []
    for seed, (r, h) in enumerate(zip(results, hidden), start=1):
        r['targets'] = {'fused_20pct_below_best_view': True,
                        'hidden_40pct_below_best_view': h}
        runs.append(dict(seed=seed, targets=bench.verdicts(r),
                         **bench.figures(r)))
    assert runs[0]['hidden_below_best_pct'] is None
    assert runs[0]['nearest_view_hidden_below_best_pct'] is None
    assert runs[0]['below_best_pct'] == 25.0
    met, applied = bench.targets_met(runs)
    assert met['hidden_40pct_below_best_view'] == 1
    assert applied == {'fused_20pct_below_best_view': 3,
                       'hidden_40pct_below_best_view': 1}
    s = bench.summary(runs)
    assert s['hidden_below_best_pct'] == {'median': 43.8, 'min': 43.8,
                                          'max': 43.8, 'of': 1}
    assert s['fused_m']['of'] == 3
    runs.pop(1)
    assert bench.summary(runs)['fused_hidden_m'] == {
        'median': None, 'min': None, 'max': None, 'of': 0}


def test_arguments_that_print_other_figures_are_refused():
    proc = subprocess.run([sys.executable, SCRIPT, '--motion', 'x.track',
                           '--people', '3'], capture_output=True, text=True)
    assert proc.returncode == 2
    assert '--people prints other figures' in proc.stderr
