"""Config errors that help: the valid names and the nearest match."""
import difflib
from typing import Callable, Iterable, Optional


def unknown(what: str, name: object, valid: Iterable[str],
            short: Optional[Callable[[str], str]] = None) -> str:
    """'unknown WHAT 'NAME': valid: A, B; did you mean 'A'?' for a
    ``name`` not among ``valid`` (the near match only when one is close;
    ``short(v)``: compare ``name`` with that part of each valid name too,
    e.g. a class path's class name)."""
    valid = sorted(valid)
    near = difflib.get_close_matches(str(name), valid, n=1)
    if not near and short is not None:
        by_short = {short(v): v for v in valid}
        near = [by_short[m] for m in difflib.get_close_matches(
            short(str(name)), list(by_short), n=1)]
    return 'unknown %s %r: valid: %s%s' % (
        what, name, ', '.join(valid) or '(none)',
        "; did you mean %r?" % near[0] if near else '')


def unknown_keys(what: str, keys: Iterable[str],
                 valid: Iterable[str]) -> str:
    """The ``unknown`` message of the first of ``keys`` not in ``valid``
    ('' when every key is valid)."""
    valid = list(valid)
    bad = sorted(k for k in keys if k not in valid)
    return unknown(what, bad[0], valid) if bad else ''
