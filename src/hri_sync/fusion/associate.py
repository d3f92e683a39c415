"""The same person across views, under one id for the session.

Each view's tracked user (a ``(view, user)`` key) is tied to a fused
person. Distances between bodies are along the floor (``body_distance``):
people stand apart, while a view's skeleton of someone half hidden, or of a
user its tracker has just found, may sit too high or too low. A key keeps
its person while its skeleton stays within ``keep_gate`` of that person's
last fused body, or until it is within ``gate`` of another person whom no
other key of its view holds and half as far from them as from its own. A
key farther away has been given to someone else by its tracker (as
trackers do when people cross, or when they find a lost user again) or its
skeleton went astray: it moves to another person within ``gate`` that no
other key of its view holds, or else is left out
(``jumps`` counts the instants) and only let go after ``release_after`` s
far away, when it is a new key again. A new key joins the nearest person
within ``gate`` that no other key of the same view holds (so two people
close together stay two), or starts a new person (so a person seen by one
view only is still a person). Both gates grow by ``max_speed`` times the
time since the person was last seen. A person that one view gives while
that view has never shared a person with another view, within
``hold_near`` of a person two other views agree on, is held back
(``held``) for ``hold`` s at most: the view's pose may be wrong
(hri_sync.fusion.pipeline fits it; its users then join that person), or
else (``release``, or a second view joins them) they are someone else.
Two persons whose bodies overlap (``merge_gate``) for ``merge_after`` s
while no view sees both are one: the younger id joins the older. A person
seen by no view for ``forget_after`` s is dropped; ids are never reused:
not a person whose view gives it now and gave it with no break of
``forget_after`` s since it was last fused (a fusion that fell behind skips
instants, while its views went on seeing the person, perhaps with short
breaks of their own: a starved machine starves their node too). A
dropped person comes back when a tracker's user of it gives a body again
within ``resume_after`` s of when it was last fused, within ``keep_gate``
of where it was (grown by the time): the tracker kept its user's id
through the break. Time the fusion was deaf (it heard from no view:
``deaf(start, end)``, hri_sync.fusion.views) is not counted in those
``resume_after`` s: no view could say the person had gone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Dict, Hashable, Optional, Set, Tuple

import numpy as np

from hri_sync.dance_off.joints import INDEX

Key = Tuple[str, Hashable]      # (view, user id)

CORE = [INDEX[j] for j in ('neck', 'torso', 'left_shoulder',
                           'right_shoulder', 'left_hip', 'right_hip')]


def body_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Median distance (m) along the floor (world x, y) of the core joints
    both bodies have (all joints when they share none); inf when they
    share no joint."""
    d = np.linalg.norm(a[:, :2] - b[:, :2], axis=1)
    core = d[CORE][np.isfinite(d[CORE])]
    if core.size:
        return float(np.median(core))
    d = d[np.isfinite(d)]
    return float(np.median(d)) if d.size else np.inf


def views_of(ids: Dict[Key, int]) -> Dict[int, Set[str]]:
    """The views of each person of an instant's keys."""
    out: Dict[int, Set[str]] = {}
    for (view, _), pid in ids.items():
        out.setdefault(pid, set()).add(view)
    return out


@dataclass
class Person:
    """A fused person: last body, last time seen, when first seen."""

    positions: np.ndarray
    seen: float
    born: float
    overlap: Dict[int, float] = field(default_factory=dict)
    held_since: Optional[float] = None  # -inf: let go


class Associator:
    """Keys to person ids, instant by instant."""

    def __init__(self, gate: float = 0.5, keep_gate: float = 0.75,
                 merge_gate: float = 0.25, merge_after: float = 0.5,
                 forget_after: float = 1.0, release_after: float = 2.0,
                 max_speed: float = 2.0, hold: float = 3.0,
                 hold_near: float = 2.0, resume_after: float = 3.0) -> None:
        self.hold = hold
        self.hold_near = hold_near
        self.confirmed: Set[str] = set()   # views that shared a person
        self.gate = gate
        self.keep_gate = keep_gate
        self.max_speed = max_speed
        self.merge_gate = merge_gate
        self.merge_after = merge_after
        self.forget_after = forget_after
        self.release_after = release_after
        self.resume_after = resume_after
        self.far_since: Dict[Key, float] = {}
        self.jumps = 0             # instants a key was left out as a jump
        self.persons: Dict[int, Person] = {}
        self.forgotten: Dict[int, Person] = {}  # for resume_after s
        self.owner: Dict[Key, int] = {}
        self.next_id = 1
        self.switches = 0          # keys moved from one person to another

    def assign(self, t: float, bodies: Dict[Key, np.ndarray],
               since: Optional[Callable[[Key], float]] = None,
               deaf: Optional[Callable[[float, float], float]] = None
               ) -> Dict[Key, int]:
        """Person id of each key's body (15, 3) at instant ``t``;
        ``since(key)``: when that key's samples began without a break of
        ``forget_after`` s (the fusion's tracks; None: not known);
        ``deaf(start, end)``: the seconds between that the fusion heard
        from no view (None: 0)."""
        for pid in [p for p, person in self.persons.items()
                    if t - person.seen > self.forget_after
                    and not self._followed(p, bodies, since)]:
            self.forgotten[pid] = self.persons.pop(pid)
        self._resume(t, bodies, deaf or (lambda start, end: 0.0))
        out: Dict[Key, int] = {}
        moved, doubtful = set(), {}
        for key in sorted(bodies, key=str):
            owner = self.owner.get(key)
            if owner is None or owner not in self.persons:
                continue
            d = self._near(t, bodies[key], owner, self.keep_gate)
            if d is not None:
                out[key] = owner
                self.far_since.pop(key, None)
                if d > self.gate:
                    doubtful[key] = d
            elif t - self.far_since.setdefault(key, t) < self.release_after:
                moved.add(key)
            else:
                del self.owner[key], self.far_since[key]
        for key in sorted(doubtful, key=str):
            self._reconsider(t, key, bodies[key], doubtful[key], out)
        self.jumps += len(self._join(t, bodies, out, moved))
        for key, pid in out.items():
            if self.owner.get(key, pid) != pid:
                self.switches += 1
                self.far_since.pop(key, None)
            self.owner[key] = pid
        out = self._merge(t, bodies, out)
        self._hold(t, out)
        return out

    def _followed(self, pid: int, bodies: Dict[Key, np.ndarray],
                  since: Optional[Callable[[Key], float]]) -> bool:
        """Whether a key of person ``pid`` gives a body now and has given
        one without a break of ``forget_after`` s since the person was
        last fused (the fusion skipped the instants between)."""
        seen = self.persons[pid].seen
        return since is not None and any(
            self.owner.get(k) == pid and since(k) <= seen + self.forget_after
            for k in bodies)

    def _resume(self, t: float, bodies: Dict[Key, np.ndarray],
                deaf: Callable[[float, float], float]) -> None:
        """Bring back each person forgotten within ``resume_after`` s of
        when it was last fused (less the time the fusion was deaf) whose
        key gives a body within ``keep_gate`` of its last one (grown by
        the time); let go of the older ones."""
        for old in [p for p, person in self.forgotten.items()
                    if t - person.seen - deaf(person.seen, t)
                    > self.resume_after]:
            del self.forgotten[old]
        for key in sorted(bodies, key=str):
            owner = self.owner.get(key)
            person = None if owner is None else self.forgotten.get(owner)
            if person is not None and owner is not None and self._within(
                    t, bodies[key], person, self.keep_gate) is not None:
                self.persons[owner] = self.forgotten.pop(owner)

    def held(self, pid: int, t: float) -> bool:
        """Whether person ``pid`` is held back at ``t``."""
        since = self.persons[pid].held_since
        return since is not None and t - since < self.hold

    def release(self, view: str) -> None:
        """The persons held back for ``view`` are people: no longer held."""
        for key, pid in self.owner.items():
            if key[0] == view and pid in self.persons:
                self.persons[pid].held_since = -math.inf

    def _hold(self, t: float, out: Dict[Key, int]) -> None:
        """Hold back the persons that one view alone gives while it has
        never shared a person with the others, near a person two other
        views agree on; let go of those a second view joins."""
        views = views_of(out)
        self.confirmed |= {v for vs in views.values() if len(vs) > 1
                           for v in vs}
        for pid, vs in views.items():
            person = self.persons[pid]
            if len(vs) > 1:             # two views agree: someone
                person.held_since = -math.inf
            if person.held_since is not None or len(vs) > 1 \
                    or vs & self.confirmed:
                continue
            if any(len(other) > 1 and not other & vs and body_distance(
                    person.positions, self.persons[q].positions)
                    <= self.hold_near for q, other in views.items()):
                person.held_since = t

    def _near(self, t: float, body: np.ndarray, pid: int, gate: float
              ) -> Optional[float]:
        """The distance of ``body`` from person ``pid`` when within
        ``gate`` (grown by the time the person was not seen), else
        None."""
        return self._within(t, body, self.persons[pid], gate)

    def _within(self, t: float, body: np.ndarray, person: Person,
                gate: float) -> Optional[float]:
        """``_near`` for a ``person`` given."""
        d = body_distance(body, person.positions)
        grown = gate + self.max_speed * max(t - person.seen, 0.0)
        return d if d <= grown else None

    def _reconsider(self, t: float, key: Key, body: np.ndarray, d: float,
                    out: Dict[Key, int]) -> None:
        """A key kept ``d`` from its person, beyond ``gate``, moves to
        another person free in its view within gate and half as far."""
        taken = {p for k, p in out.items() if k[0] == key[0]}
        near = [(e, pid) for pid in self.persons if pid not in taken
                for e in [self._near(t, body, pid, min(self.gate, d / 2))]
                if e is not None]
        if near:
            out[key] = min(near)[1]

    def _join(self, t: float, bodies: Dict[Key, np.ndarray],
              out: Dict[Key, int], moved: set) -> set:
        """Keys without a person to the nearest free person within gate;
        new ids for the others, but for ``moved`` keys (far from their
        own person), which are left out: returned."""
        left = sorted((k for k in bodies if k not in out), key=str)
        jumped = set()
        while left:
            best: Optional[Tuple[float, Key, int]] = None
            for key in left:
                taken = {p for k, p in out.items() if k[0] == key[0]}
                for pid in self.persons:
                    d = None if pid in taken else \
                        self._near(t, bodies[key], pid, self.gate)
                    if d is not None and (best is None or d < best[0]):
                        best = (d, key, pid)
            if best is not None:
                _, key, pid = best
                out[key] = pid
            elif left[0] in moved:
                key = left[0]
                jumped.add(key)
            else:
                key, pid = left[0], self.next_id
                self.next_id += 1
                self.persons[pid] = Person(bodies[key].copy(), t, t)
                out[key] = pid
            left.remove(key)
        return jumped

    def _merge(self, t: float, bodies: Dict[Key, np.ndarray],
               out: Dict[Key, int]) -> Dict[Key, int]:
        """Join persons that overlap long enough with no view in common."""
        views = views_of(out)
        ids = sorted(views)
        for i, a in enumerate(ids):
            for b in ids[i + 1:]:
                pa, pb = self.persons[a], self.persons[b]
                close = not (views[a] & views[b]) and body_distance(
                    pa.positions, pb.positions) <= self.merge_gate
                if not close:
                    pa.overlap.pop(b, None)
                    continue
                since = pa.overlap.setdefault(b, t)
                if t - since >= self.merge_after:
                    old, young = (a, b) if pa.born <= pb.born else (b, a)
                    out = {k: old if p == young else p
                           for k, p in out.items()}
                    self.owner.update(out)
                    self.persons.pop(young, None)
                    return self._merge(t, bodies, out)
        return out

    def update(self, pid: int, positions: np.ndarray, t: float) -> None:
        """The person's fused body at ``t`` (the reference next time)."""
        person = self.persons[pid]
        keep = ~np.isfinite(positions).all(axis=1)
        new = positions.copy()
        new[keep] = person.positions[keep]
        person.positions = new
        person.seen = t
