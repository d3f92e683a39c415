"""No function in src/ over 80 lines without a reason: a comment starting
'Over 80 lines:' just above it (C++) or at the top of its body (Python)."""
import ast
import glob
import os
import re

ROOT = os.path.join(os.path.dirname(__file__), '..', '..')
LIMIT = 80
REASON = 'Over 80 lines:'


def python_functions(path):
    """(name, first line, lines, has a reason) of every function."""
    with open(path) as f:
        text = f.read()
    lines = text.split('\n')
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            first = node.body[0].end_lineno + 2
            body = '\n'.join(lines[node.lineno - 1:first])
            yield (node.name, node.lineno, node.end_lineno - node.lineno + 1,
                   REASON in body)


def cpp_functions(path):
    """(signature, first line, lines, has a reason) of every top-level
    brace block that is not a namespace, class, struct or enum."""
    with open(path) as f:
        lines = f.read().split('\n')
    stack = []                  # (line index, is a function)
    for i, line in enumerate(lines):
        code = re.sub(r'//.*', '', line)
        code = re.sub(r'"(\\.|[^"\\])*"', '""', code)
        code = re.sub(r"'(\\.|[^'\\])'", "''", code)
        for ch in code:
            if ch == '{':
                head = ' '.join(lines[max(0, i - 2):i + 1])
                kind = re.search(r'\b(namespace|class|struct|enum)\b[^;(]*$',
                                 head.split(';')[-1])
                stack.append((i, not kind and not any(f for _, f in stack)))
            elif ch == '}' and stack:
                start, function = stack.pop()
                if function:
                    above = '\n'.join(lines[max(0, start - 4):start + 1])
                    yield (lines[start].strip()[:60], start + 1,
                           i - start + 1, REASON in above)


def long_functions():
    found = []
    for path in glob.glob(os.path.join(ROOT, 'src', '**', '*.py'),
                          recursive=True):
        found += [(path,) + f for f in python_functions(path)]
    for path in glob.glob(os.path.join(ROOT, 'src', '**', '*.cpp'),
                          recursive=True):
        found += [(path,) + f for f in cpp_functions(path)]
    return [f for f in found if f[3] > LIMIT]


def test_every_long_function_says_why():
    bad = ['%s:%d %s (%d lines)' % (os.path.relpath(p, ROOT), line, name, n)
           for p, name, line, n, reason in long_functions() if not reason]
    assert not bad, 'split these or say why:\n' + '\n'.join(bad)


def test_the_scan_sees_long_functions(tmp_path):
    body = '\n'.join('    x = %d' % i for i in range(LIMIT))
    py = tmp_path / 'a.py'
    py.write_text('def f():\n%s\n' % body)
    assert [(n, r) for n, _, n_lines, r in python_functions(str(py))
            if n_lines > LIMIT] == [('f', False)]
    cpp = tmp_path / 'a.cpp'
    cpp.write_text('namespace a {\nstruct S { int x; };\nint f() {\n%s\n}\n}\n'
                   % '\n'.join('  x(%d);' % i for i in range(LIMIT)))
    long = [f for f in cpp_functions(str(cpp)) if f[2] > LIMIT]
    assert [(f[0], f[3]) for f in long] == [('int f() {', False)]
