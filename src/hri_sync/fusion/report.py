"""What the fusion says on /diagnostics, as plain statuses.

``view <id>``: the view's faults (ERROR when it is left out: stalled,
frozen, clock lost; WARN: no data yet, its sensor tracking no one,
repeated skeletons, bad stamps,
NaN joints, joints at the sensor's origin or beyond its depth, wrong
pose), its pipeline
latency and stamp uncertainty; ``calibration``: the residual (mm) of each
pair of views (WARN over the threshold); ``people``: the fused people,
with the views each is fused from and whether its left and right are in
doubt (hri_sync.fusion.facing), id switches, left-out jumps and the
fused latency (output time less the newest capture used, p95); WARN
``behind`` when every view's skeletons came over ``max_age`` after their
capture (this node starved, its host's clock behind, or a recording
played to it off ``/use_sim_time``).
"""

from __future__ import annotations

from typing import List, Optional, Tuple

from hri_sync.fusion.pipeline import Frame, Fusion
from hri_sync.fusion.views import RULES

OK, WARN, ERROR = 0, 1, 2       # diagnostic_msgs/DiagnosticStatus levels
LATENCY = 'latency p95 after the newest capture (ms)'   # people's key
LEFT_OUT = ('stalled', 'frozen', 'clock_lost')

Status = Tuple[str, int, str, List[Tuple[str, str]]]
VIEW = 'view '                  # a view's status: VIEW + its id


def view_named(name: str) -> Optional[str]:
    """The view whose status this is, from its name on /diagnostics
    (``<node>: view <id>``, as diagnostic_updater names it); None for
    any other status."""
    _, sep, rest = name.partition(': ' + VIEW)
    return rest if sep and rest else None


def view_status(fusion: Fusion, view: str) -> Status:
    """One view's status."""
    faults = fusion.faults()[view]
    health = fusion.health[view]
    level = max([ERROR if f in LEFT_OUT else WARN for f, _ in faults],
                default=OK)
    message = '; '.join('%s: %s' % f for f in faults) or 'fused'
    values = [('faults', ' '.join(f for f, _ in faults) or 'none'),
              ('skeletons', str(health.arrivals)),
              ('latency p95 (ms)', '%.1f' % (health.latency() * 1e3)),
              ('period (ms)', '%.1f' % (health.period() * 1e3)),
              ('stamp uncertainty (ms)',
               '%.3f' % (health.last_uncertainty * 1e3)),
              *[(name, str(getattr(health, counter)))
                for name, counter in RULES.items()],
              ('beyond range', str(health.beyond_range)),
              ('joints out of image', str(health.out_of_image)),
              ('hands out of reach', str(health.out_of_reach))]
    values += [('rejected ' + r, str(n))
               for r, n in sorted(health.rejected.items())]
    return VIEW + view, level, message, values


def calibration_status(fusion: Fusion) -> Status:
    """The residual of every pair of views, and the views whose pose is
    wrong: down-weighted, and placed by a pose fitted to the others'."""
    ready = fusion.residuals.ready()
    blamed, unexplained = fusion.residuals.wrong()
    values = [('%s-%s (mm)' % pair, '%.0f' % (r * 1e3))
              for pair, r in sorted(ready.items())]
    values += [('%s fitted pose' % view, '%.3f %.3f %.3f %.4f %.4f' % (
        p.x, p.y, p.z, p.yaw, p.pitch)) for view, (p, _, _) in
        sorted(fusion.fitted.items())]
    wrong = sorted(set(blamed) | set(fusion.fitted))
    if wrong:
        return ('calibration', WARN, 'wrong pose: %s (down-weighted)' % '; '
                .join(v + _fitted(fusion, v) for v in wrong), values)
    if unexplained:
        return ('calibration', WARN, 'residual over %.0f mm: %s'
                % (fusion.residuals.threshold * 1e3,
                   ', '.join('%s-%s' % p for p in unexplained)), values)
    if not ready:
        return 'calibration', OK, 'no pair of views sees a person yet', []
    return 'calibration', OK, 'views agree', values


def _fitted(fusion: Fusion, view: str) -> str:
    """', placed by a fitted pose' and its residuals, if ``view`` is."""
    if view not in fusion.fitted:
        return ''
    _, before, after = fusion.fitted[view]
    return (', placed by a pose fitted to the other views: %.0f mm off, '
            '%.0f mm after' % (before * 1e3, after * 1e3))


def people_status(fusion: Fusion, last: Frame | None) -> Status:
    """The fused people of the last frame."""
    people = last.people if last else []
    values = [('person %d views' % p.person, ' '.join(p.body.views))
              for p in people]
    values += [('person %d sides' % p.person,
                'in doubt' if p.sides_in_doubt else 'sure') for p in people]
    values += [('id switches', str(fusion.associator.switches)),
               ('jumps left out', str(fusion.associator.jumps)),
               (LATENCY, '%.1f' % (fusion.latency() * 1e3))]
    now, window = fusion.clock(), fusion.params.health.window
    behind = sum(now - t <= window for t in fusion.behind)
    if behind:
        return 'people', WARN, (
            '%d fused; behind: %d skeletons came over %.1f s after their '
            "capture in %.0f s, every view's alike (this node starved, its "
            "host's clock off the global clock: clock_state:=, or a "
            "recording played without use_sim_time and --clock)"
            % (len(people), behind, fusion.params.max_age, window)), values
    return 'people', OK, '%d fused' % len(people), values


def statuses(fusion: Fusion, last: Frame | None) -> List[Status]:
    """Every status of the fusion now."""
    return ([view_status(fusion, v) for v in sorted(fusion.poses)]
            + [calibration_status(fusion), people_status(fusion, last)])
