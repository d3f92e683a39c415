"""Skeletons drawn for rviz: joints, bones, colours, the winner (no ROS).

The core of ``nodes/skeleton_markers``: ``draw`` turns one skeleton (15
Skeleton positions and their confidences) into a ``Drawing`` in the
sensor's tf frame (``frames.skeleton_point``):
joint points and bone segments, each coloured by confidence (red at 0,
yellow at 0.5, green at 1), and a label; the winner of the last decision
is drawn with thicker bones and a gold label. ``Winner`` follows the
decisions: the last winner stays highlighted until the next round starts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hri_sync.dance_off.frames import skeleton_point
from hri_sync.dance_off.joints import INDEX, NUM_JOINTS
from hri_sync.decision.rule import WINNER

BONES = tuple((INDEX[a], INDEX[b]) for a, b in (
    ('head', 'neck'), ('neck', 'left_shoulder'), ('neck', 'right_shoulder'),
    ('left_shoulder', 'left_elbow'), ('left_elbow', 'left_hand'),
    ('right_shoulder', 'right_elbow'), ('right_elbow', 'right_hand'),
    ('left_shoulder', 'torso'), ('right_shoulder', 'torso'),
    ('torso', 'left_hip'), ('torso', 'right_hip'), ('left_hip', 'right_hip'),
    ('left_hip', 'left_knee'), ('left_knee', 'left_foot'),
    ('right_hip', 'right_knee'), ('right_knee', 'right_foot')))

BONE_WIDTH = 0.03           # m
WINNER_BONE_WIDTH = 0.06    # m
GOLD = (1.0, 0.84, 0.0, 1.0)
WHITE = (1.0, 1.0, 1.0, 1.0)


def confidence_colour(c: float) -> tuple[float, ...]:
    """(r, g, b, a): red at 0, yellow at 0.5, green at 1; NaN is grey."""
    if not math.isfinite(c):
        return (0.5, 0.5, 0.5, 1.0)
    c = min(max(c, 0.0), 1.0)
    return (min(1.0, 2 * (1 - c)), min(1.0, 2 * c), 0.0, 1.0)


@dataclass
class Drawing:
    """What to draw of one skeleton, in its sensor's tf frame."""

    points: list            # joint positions (x, y, z)
    point_colours: list
    segments: list          # bone ends, two points per bone
    segment_colours: list   # one per end, as rviz's LINE_LIST wants
    bone_width: float
    label: str
    label_at: tuple
    label_colour: tuple


def draw(client_id: str, positions: list[tuple[float, ...]],
         confidence: list[float], winner: bool = False) -> Drawing:
    """The Drawing of one skeleton; joints with a non-finite position are
    left out, with their bones. ``winner``: highlight it."""
    if len(positions) != NUM_JOINTS or len(confidence) != NUM_JOINTS:
        raise ValueError('a skeleton has %d joints, not %d positions and %d '
                         'confidences' % (NUM_JOINTS, len(positions),
                                          len(confidence)))
    positions = [skeleton_point(p) for p in positions]
    seen = [all(math.isfinite(v) for v in p) for p in positions]
    points, point_colours = [], []
    for p, c, ok in zip(positions, confidence, seen):
        if ok:
            points.append(p)
            point_colours.append(confidence_colour(c))
    segments, segment_colours = [], []
    for a, b in BONES:
        if seen[a] and seen[b]:
            colour = confidence_colour(min(confidence[a], confidence[b]))
            segments += [positions[a], positions[b]]
            segment_colours += [colour, colour]
    head = positions[INDEX['head']]
    above = (head[0], head[1] + 0.35, head[2]) if seen[INDEX['head']] \
        else (0.0, 0.0, 0.0)
    return Drawing(points, point_colours, segments, segment_colours,
                   WINNER_BONE_WIDTH if winner else BONE_WIDTH,
                   '%s: WINNER' % client_id if winner else client_id,
                   above, GOLD if winner else WHITE)


class Winner:
    """The client to highlight: the last decision's winner, until the
    next round's capture starts."""

    def __init__(self) -> None:
        self.client = ''

    def on_decision(self, outcome: str, winner: int,
                    clients: list[str]) -> None:
        """A Decision: ``winner`` is 1-based among its ``clients``."""
        ok = outcome == WINNER and 1 <= winner <= len(clients)
        self.client = clients[winner - 1] if ok else ''

    def on_capture(self) -> None:
        """A new round's CaptureData: nobody is the winner yet."""
        self.client = ''
