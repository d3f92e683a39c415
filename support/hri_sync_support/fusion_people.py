"""Several people crossing in the fusion bench (bench/fusion_accuracy.py
``--people``): walkers made from the walk clip, and the fused people
scored against the rendered truth (ids kept, id switches, duplicates,
people missing).

A walker repeats the walk clip's steadiest gait cycle along a straight
path; away from its crossings it stands far below the floor, where no view
sees it. Scoring matches, at each fused instant, the fused bodies to the
people present (Hungarian, on the distance along the floor between the
means of their core joints, within ``GATE``): a person whose matched id
differs from the id it had when last matched is an id switch, or a
re-entry when no view saw the person for more than ``LEFT`` s in between
(the fusion forgets a person no view sees); an id matched to another
person than it was last matched to is an id transfer; a fused body matched to
nobody is a duplicate (an id that is matched at fewer than half of its
instants is a duplicate person); a person some view tracks with no fused
body matched is missing.
"""
import math

import numpy as np
from scipy.optimize import linear_sum_assignment

from hri_sync.dance_off.joints import INDEX
from hri_sync.dance_off.motion import Motion

GATE = 0.5          # m, a fused body and a person are the same
LEFT = 1.0          # s unseen by every view: a new id is a re-entry
AWAY = -50.0        # m, a walker's height between crossings
HIPS = [INDEX['left_hip'], INDEX['right_hip']]
CORE = [INDEX[j] for j in ('neck', 'torso', 'left_shoulder',
                           'right_shoulder', 'left_hip', 'right_hip')]


def where(body):
    """A body's place on the floor: the mean (x, y) of its core joints,
    or of all its joints when it has no core joint (NaN: none)."""
    core = body[CORE, :2]
    if not np.isfinite(core).all(axis=1).any():
        core = body[:, :2]
    ok = np.isfinite(core).all(axis=1)
    return core[ok].mean(axis=0) if ok.any() else np.full(2, np.nan)


def _hips(walk, t):
    return walk.positions_at(np.atleast_1d(t), 'clamp')[:, HIPS].mean(
        axis=1)


def gait_cycle(walk, starts=(4.3, 5.0), periods=(0.8, 1.6), step=1 / 120):
    """(start, period, displacement (3,)) of the walk's steadiest cycle in
    world: the stretch from ``start`` whose pose, relative to the hips,
    comes back closest after ``period`` s while the hips move on."""
    best = (math.inf, None)
    for t0 in np.arange(starts[0], starts[1], step):
        for period in np.arange(periods[0], periods[1], step):
            p = walk.positions_at([t0, t0 + period], 'clamp')
            rel = p - np.concatenate([p[:, HIPS].mean(axis=1)[:, :2],
                                      np.zeros((2, 1))], axis=1)[:, None]
            err = np.linalg.norm(rel[0] - rel[1], axis=1).mean()
            if err < best[0]:
                best = (err, (float(t0), float(period)))
    t0, period = best[1]
    d = (_hips(walk, t0 + period) - _hips(walk, t0))[0]
    d[2] = 0.0
    return t0, period, d


def walker(walk, cycle, crossings, duration, rate=60.0):
    """World Motion of a walker over ``duration`` s: each crossing
    (start s, centre (x, y), heading rad, length m) walks the gait cycle
    through the centre along the heading, from length / 2 before it to
    length / 2 after; elsewhere the first pose stands at AWAY."""
    t0, period, d = cycle
    speed = np.linalg.norm(d) / period
    base = _hips(walk, t0)[0]
    base[2] = 0.0
    turn0 = math.atan2(d[1], d[0])
    times = np.arange(int(duration * rate) + 1) / rate
    away = walk.positions_at([t0], 'clamp')[0] - base + [0.0, 0.0, AWAY]
    out = np.repeat(away[None], len(times), axis=0)
    for start, centre, heading, length in crossings:
        tau = times - start
        on = (tau >= 0) & (tau <= length / speed)
        k = np.floor(tau[on] / period)
        pose = walk.positions_at(t0 + tau[on] - k * period, 'clamp') - base
        pose += (k[:, None] * d)[:, None]
        c, s = math.cos(heading - turn0), math.sin(heading - turn0)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        back = np.array([math.cos(heading), math.sin(heading), 0.0])
        out[on] = pose @ rot.T + [centre[0], centre[1], 0.0] \
            - back * length / 2
    return Motion(times, out, name='walker')


def present(truth):
    """Whether each person's truth (..., 15, 3) is in the room."""
    return truth[..., INDEX['torso'], 2] > AWAY / 2


def match(bodies, people, gate=GATE):
    """{fused index: person index} of one instant: bodies (F, 15, 3),
    people (P, 15, 3), pairs within ``gate`` m at the least total
    distance."""
    if not len(bodies) or not len(people):
        return {}
    cost = np.linalg.norm(np.array([where(b) for b in bodies])[:, None]
                          - np.array([where(p) for p in people])[None],
                          axis=2)
    cost = np.where(np.isfinite(cost), cost, np.inf)
    rows, cols = linear_sum_assignment(np.minimum(cost, 1e6))
    return {int(r): int(c) for r, c in zip(rows, cols)
            if cost[r, c] <= gate}


class Timeline:
    """Each person's fused ids over the instants."""

    def __init__(self):
        self.last = {}          # person: id last matched
        self.unseen = {}        # person: unseen by every view since
        self.left = set()       # people unseen for LEFT s since matched
        self.person_of = {}     # id: person last matched
        self.switches = []      # (t, person, id before, id now)
        self.reentries = self.transfers = 0

    def watch(self, t, person, watched):
        """Whether some view sees ``person`` at ``t``."""
        if not watched:
            self.unseen.setdefault(person, t)
        elif t - self.unseen.pop(person, t) > LEFT:
            self.left.add(person)

    def matched(self, t, person, pid):
        """``person`` is fused as ``pid`` at ``t``."""
        if t - self.unseen.get(person, t) > LEFT:
            self.left.add(person)
        if self.last.get(person, pid) != pid:
            if person in self.left:
                self.reentries += 1
            else:
                self.switches.append((round(t, 2), person,
                                      self.last[person], pid))
        self.transfers += self.person_of.get(pid, person) != person
        self.left.discard(person)
        self.last[person] = pid
        self.person_of[pid] = person


def score(instants, truth, seen):
    """The association figures. ``instants``: [(t, [(id, body (15, 3))])]
    per fused instant; ``truth(t)``: the people (P, 15, 3) at t (in the
    room or not: ``present``); ``seen(t)``: (P,) bool, whether some view
    tracks each person at t."""
    line, ids, errors = Timeline(), {}, {}
    duplicates = missing = tracked = 0
    for t, fused in instants:
        people = truth(t)
        here = np.flatnonzero(present(people))
        watched = seen(t)
        for person in range(len(people)):
            line.watch(t, person, watched[person] and person in here)
        pairs = match(np.array([b for _, b in fused]), people[here])
        for f, (pid, body) in enumerate(fused):
            hit = ids.setdefault(pid, [0, 0])
            hit[1] += 1
            if f not in pairs:
                duplicates += 1
                continue
            hit[0] += 1
            person = int(here[pairs[f]])
            line.matched(t, person, pid)
            errors.setdefault(person, []).append(np.nanmean(
                np.linalg.norm(body - people[person], axis=1)))
        matched = {int(here[p]) for p in pairs.values()}
        for person in here:
            if watched[person]:
                tracked += 1
                missing += person not in matched
    count = len(truth(instants[0][0])) if instants else 0
    return {
        'id_switches': len(line.switches),
        'id_switch_at': line.switches,
        'id_transfers': line.transfers,
        'reentries': line.reentries,
        'duplicate_people': sum(2 * h < n for h, n in ids.values()),
        'duplicate_instants': duplicates,
        'missing_people': missing,
        'missing_share': round(missing / max(tracked, 1), 4),
        'person_instants_seen': tracked,
        'fused_ids': len(ids),
        'fused_mean_m': [round(float(np.mean(errors[p])), 4)
                         if p in errors else None for p in range(count)],
    }
