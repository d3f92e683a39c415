"""A recording's fused people, their sides in doubt put right from later.

Live, the fusion decides at each instant which way a person faces from
what the views give then (hri_sync.fusion.facing); where nothing decides
(the hands near the trunk, the views split evenly, the head's lead too
small) a person's left and right stay in doubt, and can be exchanged
until the hands first reach out: on real Kinect v1 recordings of people
punching who face one sensor, for up to a second at the start
(docs/fusion.md). A recording fused afterwards can look ahead: no one
turns about in an instant, so a person's front from one fused instant to
the next (``max_step`` s apart or less) turns by well under a right
angle. From each instant whose sides were sure, back through the
instants before it whose sides were in doubt, each instant is given the
labels whose front continues the one after it (every left and right
joint exchanged where it points the other way). As live, where one
instant of the hands can be a tracker's slip, a sure instant the chain
reaches alone (the person's next instant in doubt, or sure with its
front the other way) is carried by it like one in doubt. A sure instant
the next confirms, or one no chain from later reaches, starts a chain of
its own; a chain ends at two fronts more than 45 degrees from one line
(an exchange the joint filter spread over several instants, or a turn:
it tells neither from the other), or at a gap of over ``max_step`` s
between instants that have a front (hips and neck given, the hips apart:
an instant without one, sure or in doubt, is passed over and kept as it
is); instants in doubt after a person's last sure one keep their labels.
Their bounds, which take in both sides where the sides are in doubt, are
kept (moved with their joints), and so is the doubt.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Dict, List, Optional, Tuple

import numpy as np

from hri_sync.fusion.arms import turned
from hri_sync.fusion.facing import front
from hri_sync.fusion.pipeline import Frame, Person

MAX_STEP = 0.25     # s between fused instants the chain crosses
LEAST_COS = 0.7     # the fronts it compares lie within 45 degrees


def exchanged_sides(person: Person) -> Person:
    """``person`` with every left and right joint exchanged (positions,
    confidence, bound, sigma and scatter alike)."""
    body = person.body
    return replace(person, body=replace(
        body, positions=turned(body.positions),
        confidence=turned(body.confidence), bound=turned(body.bound),
        scatter=turned(body.scatter), sigma=turned(body.sigma)))


def labels_from_later(frames: List[Frame], max_step: float = MAX_STEP
                      ) -> Tuple[List[Frame], int]:
    """``frames`` (in time order) with the people's instants in doubt
    given their labels from the next sure instant (module docstring), and
    how many person-instants had their sides exchanged. The frames given
    are not changed."""
    people: Dict[int, List[Tuple[int, int]]] = {}
    for i, frame in enumerate(frames):
        for k, p in enumerate(frame.people):
            people.setdefault(p.person, []).append((i, k))
    out = [list(frame.people) for frame in frames]
    changed = 0
    for seq in people.values():
        timeline = [(frames[i].stamp, front(out[i][k].body.positions),
                     not out[i][k].sides_in_doubt) for i, k in seq]
        after: Optional[np.ndarray] = None     # the front of the next
        next_t = 0.0
        for n in reversed(range(len(seq))):
            t, faces, sure = timeline[n]
            if faces is None:       # judged by nothing, passed over
                continue
            if after is not None and not _continues(
                    t, faces, next_t, after, max_step):
                after = None
            if sure and (after is None or _confirmed(timeline, n, max_step)):
                after, next_t = faces, t
                continue
            if after is None:
                continue
            if faces @ after < 0:
                i, k = seq[n]
                out[i][k] = exchanged_sides(out[i][k])
                faces = -faces
                changed += 1
            after, next_t = faces, t
    return [replace(frame, people=people_at)
            for frame, people_at in zip(frames, out)], changed


def _continues(t: float, faces: np.ndarray, later: float,
               after: np.ndarray, max_step: float) -> bool:
    """Whether the front ``faces`` at ``t`` and ``after`` at ``later``
    are near enough in time and direction to tell an exchange from a
    turn."""
    return later - t <= max_step and abs(faces @ after) >= LEAST_COS


def _confirmed(timeline: List[Tuple[float, Optional[np.ndarray], bool]],
               n: int, max_step: float) -> bool:
    """Whether the sure instant ``n`` of a person's ``timeline`` (stamp,
    front, sure) is confirmed: the person's next instant is sure too and
    its front continues this one's the same way round."""
    if n + 1 >= len(timeline):
        return False
    t, faces, _ = timeline[n]
    later, after, sure = timeline[n + 1]
    return bool(sure and after is not None and faces is not None
                and _continues(t, faces, later, after, max_step)
                and faces @ after > 0)
