"""The public API of the typed core modules is annotated (mypy checks it in
`make check`); times carry their clock's type (hri_sync.wire.times).

Every core module (not a ros_*.py shell) of the packages that mypy checks
(mypy.ini) is checked."""
import ast
import os

import pytest

SRC = os.path.join(os.path.dirname(__file__), '..', '..', 'src', 'hri_sync')
PACKAGES = ('wire', 'clock', 'control', 'decision', 'client_process',
            'data_process', 'dance_off')
TYPED = sorted('%s/%s' % (package, name) for package in PACKAGES
               for name in os.listdir(os.path.join(SRC, package))
               if name.endswith('.py') and not name.startswith('ros_'))


def unannotated(path):
    """'name(arg)' or 'name -> ?' for every public function or method of
    a public class that lacks an annotation."""
    with open(path) as f:
        tree = ast.parse(f.read())
    out = []

    def visit(node):
        for c in ast.iter_child_nodes(node):
            if isinstance(c, ast.ClassDef) and not c.name.startswith('_'):
                visit(c)
            elif isinstance(c, ast.FunctionDef) and (
                    not c.name.startswith('_') or c.name == '__init__'):
                args = c.args.args + c.args.kwonlyargs
                out.extend('%s(%s)' % (c.name, a.arg) for a in args
                           if a.arg not in ('self', 'cls')
                           and a.annotation is None)
                if c.returns is None:
                    out.append('%s -> ?' % c.name)
    visit(tree)
    return out


@pytest.mark.parametrize('module', TYPED)
def test_public_api_is_annotated(module):
    assert unannotated(os.path.join(SRC, module)) == []


def test_the_check_sees_a_missing_annotation(tmp_path):
    p = tmp_path / 'm.py'
    p.write_text('class A:\n    def f(self, x: int, y):\n        pass\n'
                 'def g() -> None:\n    pass\ndef _h(z):\n    pass\n')
    assert unannotated(str(p)) == ['f(y)', 'f -> ?']
