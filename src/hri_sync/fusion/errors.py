"""A view's joint error from where the joint lies: learned on views with
their truth.

The profile takes a view's error from its confidence and where its sensor
stands; the depth tracker's arms are also wrong where they say they are
seen: a hand the tracker lays on the trunk's depth points (the true hand
hidden behind the body) is as far off as a guess. Where the joint lies
tells it apart. For each of a view's joints, seven inputs:

- ``log_confidence``: log of its confidence (floored at 0.05);
- ``kind``: 0 head, neck, torso, hips; 1 shoulders; 2 elbows; 3 hands;
  4 knees; 5 feet;
- ``log_sigma``: log of the error (m, one axis) the profile gives it;
- ``toward``: how far it lies from the fused torso towards the view's
  sensor, along the floor (m; negative: behind the body);
- ``across``: how far it lies from the line through the fused torso to
  the sensor (m);
- ``across_floor``: the same along the floor (m);
- ``back``: how much of the fused body's back the view sees (0 front-on,
  1 from behind: hri_sync.fusion.facing.back_view, given; unknown
  without the fused hips and neck). A person punching towards one sensor
  hides the arms from the sensors behind, whose trackers still give them
  at full confidence: where the joints lie alone did not tell those
  views' arms from the front one's (real Kinect v1 recordings,
  docs/fusion.md).

Each depends on the instant alone: a fusion of a recording weighs the
views as the live one did (a person's bone lengths over the last seconds
gave 0.4 point more, but an instant one fusion waited for a view at and
the other did not moved them, and the weights after it).

An ``ErrorModel`` (a Poisson-loss boosted tree ensemble, log link, fitted
by ``bench/fit_error_model.py`` on views of a motion with its truth)
gives the expected squared error (m^2) from them; a third of it is the
view's variance on each axis. It knows the views as far from the
person as those it was fitted on (``distances``, m along the floor:
their 0.5 and 99.5 percentiles) and says nothing of the others. The
fusion takes from it how the views' errors on a joint compare
(hri_sync.fusion.pipeline). Evaluated here in NumPy: the fit needs
scikit-learn, the fusion does not.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

from hri_sync.dance_off.joints import INDEX
from hri_sync.fusion.fuse import LEAST_CONFIDENCE

INPUTS = ('log_confidence', 'kind', 'log_sigma', 'toward', 'across',
          'across_floor', 'back')
ROWS = 50000    # rows ErrorModel.predict walks the trees with at once
KIND = np.array([0, 0, 0, 1, 1, 2, 2, 3, 3, 0, 0, 4, 4, 5, 5], float)


def inputs(positions: np.ndarray, confidence: np.ndarray,
           sigma: np.ndarray, body: np.ndarray,
           sensor: np.ndarray, back: Optional[float]) -> np.ndarray:
    """(15, 7) the model's inputs (``INPUTS``) for one view's joints
    (``positions`` (15, 3) world, ``confidence``, ``sigma``: the profile's
    error, m) given the person's fused ``body`` (15, 3), the view's
    ``sensor`` (3,) and how much of the body's back it sees (``back``:
    hri_sync.fusion.facing.back_views, found once for every view)."""
    torso = body[INDEX['torso']]
    to = np.asarray(sensor, float)[:2] - torso[:2]
    to = np.r_[to / max(float(np.linalg.norm(to)), 1e-9), 0.0]
    rel = positions - torso
    toward = rel @ to
    side = rel - toward[:, None] * to
    return np.column_stack([
        np.log(np.maximum(confidence, LEAST_CONFIDENCE)), KIND,
        np.log(sigma), toward, np.linalg.norm(side, axis=1),
        np.linalg.norm(side[:, :2], axis=1),
        np.full(len(positions), np.nan if back is None else back)])


@dataclass
class Tree:
    """One tree: node arrays; a leaf's ``feature`` is -1."""

    feature: np.ndarray         # (nodes,) int
    threshold: np.ndarray       # (nodes,) go left when x <= threshold
    left: np.ndarray            # (nodes,) int
    right: np.ndarray           # (nodes,) int
    value: np.ndarray           # (nodes,) a leaf's raw value
    missing_left: np.ndarray    # (nodes,) bool: NaN goes left


class ErrorModel:
    """The expected squared error (m^2) of a view's joint from its
    ``inputs``: ``exp(baseline + sum of the trees' leaves)``."""

    FIELDS = ('feature', 'threshold', 'left', 'right', 'value',
              'missing_left')

    def __init__(self, baseline: float, trees: List[Tree],
                 distances: Tuple[float, float] = (0.0, math.inf),
                 takes: int = len(INPUTS)) -> None:
        self.baseline = float(baseline)
        self.trees = trees
        self.distances = distances
        self.takes = takes      # the first of INPUTS it was fitted on
        # every tree's nodes in one array, children by their place in it
        start = np.cumsum([0] + [len(t.feature) for t in trees])
        self._start = start[:-1]
        self._nodes = {f: np.concatenate([getattr(t, f) for t in trees])
                       for f in self.FIELDS}
        for f in ('left', 'right'):
            self._nodes[f] = self._nodes[f] + np.repeat(
                self._start, np.diff(start))

    def predict(self, x: np.ndarray) -> np.ndarray:
        """(n,) expected squared errors (m^2) of rows ``x`` (n, 7), up to
        ``ROWS`` at a time (every tree is walked at once: its arrays hold
        trees x rows)."""
        return np.concatenate([self._walk(x[k:k + ROWS])
                               for k in range(0, max(len(x), 1), ROWS)])

    def _walk(self, x: np.ndarray) -> np.ndarray:
        """``predict`` of rows ``x`` all at once."""
        n, nodes = len(x), self._nodes
        column = np.ascontiguousarray(x.T).ravel()      # input-major
        node = np.repeat(self._start, n)                # (trees * n,)
        row = np.tile(np.arange(n), len(self.trees))
        live = np.arange(node.size)
        while live.size:
            at = node[live]
            feature = nodes['feature'][at]
            split = feature >= 0
            live, at, feature = live[split], at[split], feature[split]
            v = column[feature * n + row[live]]
            left = np.where(np.isnan(v), nodes['missing_left'][at],
                            v <= nodes['threshold'][at])
            node[live] = np.where(left, nodes['left'][at],
                                  nodes['right'][at])
        raw = self.baseline + nodes['value'][node].reshape(-1, n).sum(axis=0)
        return np.exp(np.clip(raw, -30.0, 5.0))

    def knows(self, distance: float) -> bool:
        """Whether a view ``distance`` m from the person is among those the
        model was fitted on."""
        return self.distances[0] <= distance <= self.distances[1]

    def to_dict(self) -> Dict[str, Any]:
        """Plain values (a YAML param)."""
        return {'inputs': list(INPUTS[:self.takes]),
                'distances': [round(float(d), 3) for d in self.distances],
                'baseline': round(self.baseline, 6),
                'trees': [{'feature': t.feature.tolist(),
                           'threshold': [float(v) for v in t.threshold],
                           'left': t.left.tolist(),
                           'right': t.right.tolist(),
                           'value': [round(float(v), 6) for v in t.value],
                           'missing_left': [int(v) for v in t.missing_left]}
                          for t in self.trees]}

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> 'ErrorModel':
        """An ErrorModel from ``to_dict``'s values; ValueError when they
        do not make one (other inputs, nodes out of range, a loop). A
        model fitted before inputs were added takes the first of
        ``INPUTS``, as many as it names."""
        named = d.get('inputs')
        named = list(named) if isinstance(named, (list, tuple)) else []
        takes = len(named)
        if not takes or named != list(INPUTS[:takes]):
            raise ValueError('an error model takes the inputs %s (or the '
                             'first of them), not %r'
                             % (list(INPUTS), d.get('inputs')))
        trees = []
        for k, t in enumerate(d.get('trees') or ()):
            try:
                a = {f: np.asarray(t[f]) for f in cls.FIELDS}
            except (KeyError, TypeError):
                raise ValueError('error model tree %d lacks one of %s'
                                 % (k, cls.FIELDS))
            n = len(a['feature'])
            tree = Tree(a['feature'].astype(int),
                        a['threshold'].astype(float),
                        a['left'].astype(int), a['right'].astype(int),
                        a['value'].astype(float),
                        a['missing_left'].astype(bool))
            split = tree.feature >= 0
            if n == 0 or any(len(a[f]) != n for f in cls.FIELDS) \
                    or (tree.feature >= takes).any() \
                    or not np.isfinite(tree.value).all() \
                    or ((tree.left <= np.arange(n))
                        | (tree.left >= n)
                        | (tree.right <= np.arange(n))
                        | (tree.right >= n))[split].any():
                raise ValueError('error model tree %d is not a tree of '
                                 'the %d inputs' % (k, takes))
            trees.append(tree)
        baseline = float(d.get('baseline', np.nan))
        if not trees or not np.isfinite(baseline):
            raise ValueError('an error model has a finite baseline and '
                             'one tree or more')
        try:
            near, far = (float(v) for v in d['distances'])
        except (KeyError, TypeError, ValueError):
            raise ValueError('an error model has the distances it knows, '
                             '[near, far] m, not %r' % d.get('distances'))
        if not 0 <= near < far:
            raise ValueError('an error model knows distances 0 <= near < '
                             'far, not %r' % [near, far])
        return cls(baseline, trees, (near, far), takes)
