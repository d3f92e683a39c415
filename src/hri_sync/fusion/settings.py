"""The fusion's settings by name: one table for the node's ``~params``
(``launch/fusion.launch``'s args) and ``fuse_bag``'s ``--set``."""

from __future__ import annotations

import math
from typing import Any, Callable, Tuple

from hri_sync.fusion.pipeline import FusionParams


def _positive(x: float) -> bool:
    return math.isfinite(x) and x > 0


def _at_least_0(x: float) -> bool:
    return math.isfinite(x) and x >= 0


Setting = Tuple[str, str, Callable[[float], bool], str]

# name, attribute of FusionParams (its default the setting's), check, the
# values it takes
SETTINGS: Tuple[Setting, ...] = (
    ('rate', 'rate', _positive, '> 0 Hz'),
    ('stall_after', 'health.stall_after', _positive, '> 0 s'),
    ('max_ahead', 'max_ahead', _positive, '> 0 s'),
    ('max_age', 'max_age', _positive, '> 0 s'),
    ('max_depth', 'max_depth', _positive, '> 0 m'),
    ('scatter_hold', 'scatter_hold', _at_least_0, '>= 0 s'),
    ('smooth_accel', 'smooth.accel', _at_least_0, '>= 0 m/s^2'),
    ('residual_threshold', 'residual_threshold', _positive, '> 0 m'),
    ('arms_margin', 'arms.margin', lambda x: x > 0, '> 0 m (inf: never)'),
    ('turn_margin', 'arms.turn_margin', lambda x: x > 0,
     '> 0 m (inf: never)'),
    ('facing_margin', 'facing.margin', lambda x: x > 0,
     '> 0 m (inf: never)'),
    ('facing_hold', 'facing.hold', _at_least_0, '>= 0 s'),
    ('facing_split_head_margin', 'facing.split_head_margin',
     lambda x: x > 0, '> 0 m (inf: never)'),
    ('facing_head_margin', 'facing.head_margin', lambda x: x > 0,
     '> 0 m (inf: never)'),
    ('facing_knee_bend', 'facing.knee_bend', _at_least_0, '>= 0 m'),
    ('hand_reach', 'reach.hand', lambda x: x > 0, '> 0 m (inf: never)'),
    ('fov_deg', 'sight.fov_deg', lambda x: 0 < x < 360, '0-360 degrees'),
    ('vertical_fov_deg', 'sight.vertical_fov_deg', lambda x: 0 < x < 180,
     '0-180 degrees'),
    ('max_range', 'sight.far', _positive, '> 0 m'),
    ('depth_range', 'sight.range', _positive, '> 0 m, >= max_range'),
)
NAMES = tuple(s[0] for s in SETTINGS)


def fusion_params(get: Callable[[str, float], Any]) -> FusionParams:
    """FusionParams from ``get(name, default)``, one value per setting
    (the default FusionParams'). Raises ValueError naming a setting that
    is not a number or out of range."""
    params = FusionParams()
    for name, attribute, check, values in SETTINGS:
        *path, last = attribute.split('.')
        owner: Any = params
        for part in path:
            owner = getattr(owner, part)
        raw = get(name, getattr(owner, last))
        try:
            value = float(raw)
        except (TypeError, ValueError):
            raise ValueError('%s=%r is not a number' % (name, raw))
        if not check(value):
            raise ValueError('%s=%r is out of range: %s'
                             % (name, value, values))
        setattr(owner, last, value)
    if params.sight.range < params.sight.far:
        raise ValueError('depth_range=%r is out of range: below max_range=%r'
                         % (params.sight.range, params.sight.far))
    return params
