"""hri_sync.wire.vocabulary: one protocol vocabulary and one set of
defaults, checked against msg/*.msg, every module and the launch files."""
import ast
import glob
import os
import re
import xml.etree.ElementTree as ET

import pytest

from hri_sync.wire import vocabulary as v

ROOT = os.path.join(os.path.dirname(__file__), '..', '..')
CONSTANT = re.compile(r'^\s*(\w+)\s+([A-Z_][A-Z0-9_]*)\s*=\s*(\S+)')


def msg_constants(name):
    """{NAME: value} of msg/<name>.msg's constants (values as text); a
    name ``Msg:PREFIX`` keeps those starting with PREFIX, ``Msg`` those
    of no prefix in ``PREFIXES``."""
    name, _, prefix = name.partition(':')
    with open(os.path.join(ROOT, 'msg', name + '.msg')) as f:
        found = {m.group(2): m.group(3) for m in map(CONSTANT.match, f)
                 if m}
    if prefix:
        return {k: v for k, v in found.items() if k.startswith(prefix)}
    return {k: v for k, v in found.items()
            if not any(k.startswith(p) for p in PREFIXES)}


PREFIXES = ('NOISE_',)    # a second set of constants in one message


def words(cls):
    return {k: getattr(cls, k) for k in vars(cls)
            if k.isupper() and isinstance(getattr(cls, k), str)}


@pytest.mark.parametrize('cls, msg', [(v.ResultStatus, 'ClientResult'),
                                      (v.NoiseSource, 'ClientResult:NOISE_'),
                                      (v.Outcome, 'Decision'),
                                      (v.RoundState, 'RoundStatus'),
                                      (v.Action, 'ActionStart'),
                                      (v.ActionEnd, 'ActionEnd')])
def test_each_word_is_its_message_constant(cls, msg):
    assert words(cls) == msg_constants(msg)
    assert set(cls.ALL) == set(msg_constants(msg).values())


def test_num_joints_is_the_skeleton_messages():
    assert v.NUM_JOINTS == int(msg_constants('Skeleton')['NUM_JOINTS'])


def sources():
    """Every Python module and node script, but the vocabulary itself."""
    paths = glob.glob(os.path.join(ROOT, 'src', 'hri_sync', '**', '*.py'),
                      recursive=True)
    paths += glob.glob(os.path.join(ROOT, 'support', '**', '*.py'),
                       recursive=True)
    paths += [p for p in glob.glob(os.path.join(ROOT, 'nodes', '*'))
              if os.path.isfile(p)]
    return [p for p in paths if not p.endswith('vocabulary.py')]


# (ActionStart's events are not scanned: LSL markers name their own.)
FIELDS = {'status', 'outcome', 'state', 'kind'}
VALUES = set(v.ResultStatus.ALL + v.Outcome.ALL + v.RoundState.ALL
             + v.Action.KINDS + v.Action.STATUSES + v.ActionEnd.STATUSES)


def field_of(node):
    """'status' for ``x.status``, ``status`` or ``x['status']``."""
    if isinstance(node, ast.Attribute):
        return node.attr
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Subscript) and isinstance(node.slice,
                                                      ast.Constant):
        return node.slice.value
    return None


def literals(node):
    """The string constants of a literal, or of a tuple/list/set of them."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return [node.value]
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return [s for e in node.elts for s in literals(e)]
    return []


def spelled_out(tree):
    """(line, word) where a protocol word is compared with, or given to,
    a status/outcome/state as a bare string."""
    found = []
    for node in ast.walk(tree):
        pairs = []
        if isinstance(node, ast.Compare):
            sides = [node.left] + node.comparators
            for a in sides:
                if field_of(a) in FIELDS:
                    pairs += [(b, node.lineno) for b in sides if b is not a]
        elif isinstance(node, ast.keyword) and node.arg in FIELDS:
            pairs.append((node.value, node.value.lineno))
        elif isinstance(node, ast.Assign) and any(
                field_of(t) in FIELDS for t in node.targets):
            pairs.append((node.value, node.lineno))
        found += [(line, s) for expr, line in pairs for s in literals(expr)
                  if s in VALUES]
    for node in tree.body:      # a second definition: WINNER = 'winner'
        if isinstance(node, ast.Assign) and any(
                isinstance(t, (ast.Name, ast.Tuple)) and all(
                    n.id.isupper() for n in ast.walk(t)
                    if isinstance(n, ast.Name)) for t in node.targets):
            found += [(node.lineno, s) for s in literals(node.value)
                      if s in VALUES]
    return found


def test_no_module_spells_out_a_protocol_word():
    bad = []
    for path in sources():
        with open(path) as f:
            text = f.read()
        if path.endswith('.py') or text.startswith('#!/usr/bin/env python') \
                or text.startswith('#!/usr/bin/python'):
            bad += ['%s:%d: %r' % (os.path.relpath(path, ROOT), line, word)
                    for line, word in spelled_out(ast.parse(text))]
    assert not bad, 'use hri_sync.wire.vocabulary:\n' + '\n'.join(bad)


def test_the_scan_finds_a_spelled_out_word():
    tree = ast.parse("if r.status == 'partial': pass\n"
                     "x = Result(status='ok')\n"
                     "ok = d['outcome'] in ('winner', 'tie')\n"
                     "USABLE = ('ok', 'late')\n")
    assert sorted(w for _, w in spelled_out(tree)) == \
        ['late', 'ok', 'ok', 'partial', 'tie', 'winner']


# Launch-file values of the shared defaults: (tag, name) -> constant.
DEFAULTS = {'max_uncertainty': v.MAX_UNCERTAINTY,
            'drift_bound': v.DRIFT_BOUND,
            'min_coverage': v.MIN_COVERAGE,
            'completion_margin': v.COMPLETION_MARGIN}


def launch_values():
    """(file, name, value) of every literal arg default or param value
    named in DEFAULTS."""
    out = []
    for path in glob.glob(os.path.join(ROOT, 'launch', '*.launch')):
        for el in ET.parse(path).getroot().iter():
            name = el.get('name')
            value = el.get('default') if el.tag == 'arg' else \
                el.get('value') if el.tag == 'param' else None
            if name in DEFAULTS and value is not None and '$(' not in value:
                out.append((os.path.basename(path), name, value))
    return out


def test_launch_files_pass_the_core_defaults():
    found = launch_values()
    assert {n for _, n, _ in found} == set(DEFAULTS)
    for launch, name, value in found:
        assert float(value) == pytest.approx(DEFAULTS[name]), (launch, name)
