"""Private ~params: read, converted and checked."""
import math

import rospy


class ParamError(Exception):
    """A ~param that is missing or wrong."""


def param(name, default=None, kind=None, check=None, why=''):
    """Read private param ``~name``; convert with ``kind`` and validate.

    Raises ParamError naming the param when it is missing (no default),
    of the wrong type, or fails ``check``.
    """
    key = '~' + name
    if not rospy.has_param(key):
        if default is None:
            raise ParamError('required param %s is not set (%s)'
                             % (rospy.resolve_name(key), why or 'no default'))
        value = default
    else:
        value = rospy.get_param(key)
    if kind is not None:
        try:
            value = kind(value)
        except (TypeError, ValueError) as e:
            raise ParamError('param %s=%r is not a valid %s: %s'
                             % (rospy.resolve_name(key), value,
                                getattr(kind, '__name__', kind), e))
    if check is not None and not check(value):
        raise ParamError('param %s=%r is out of range: %s'
                         % (rospy.resolve_name(key), value, why))
    return value


def csv_list(value):
    """A list of names from a comma-separated string or a YAML list."""
    if isinstance(value, (list, tuple)):
        items = [str(v).strip() for v in value]
    else:
        items = [v.strip() for v in str(value).split(',')]
    return [v for v in items if v]


def positive(x):
    """True for a finite number > 0."""
    return math.isfinite(x) and x > 0
