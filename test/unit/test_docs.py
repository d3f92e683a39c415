"""The README and docs/: every relative link resolves (file and heading),
no words of the project's history, and the user's reading path is short.

A newcomer reads the README and the user guide (docs/guide/) to run a
first study of their own; the reference pages are the rest of docs/.
"""
import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
DOCS = sorted([ROOT / 'README.md'] + list((ROOT / 'docs').rglob('*.md')))
GUIDE = sorted((ROOT / 'docs' / 'guide').glob('*.md'))
# README + the guide pages: what a newcomer reads to run a first study.
READING_PATH_MAX_LINES = 620

LINK = re.compile(r'(?<!!)\[[^\]]*\]\(([^)\s]+)\)')
HISTORY = re.compile(
    r'\bissues? #?\d+|\bthis round\b|\bround before\b|\bearlier rounds?\b'
    r'|\bfast hours?\b|\bslow hours?\b|\bmedium hours?\b'
    r'|\bstop \d+\b|\b20\d\d-[01]\d-[0-3]\d\b'
    r'|\b(?:jan|feb|mar|apr|may|jun|jul|aug|sep|oct|nov|dec)[a-z]* 20\d\d\b',
    re.IGNORECASE)


def strip_code(text):
    """The text without fenced code blocks and inline code spans."""
    text = re.sub(r'^```.*?^```', '', text, flags=re.S | re.M)
    return re.sub(r'`[^`\n]*`', '', text)


def slug(heading):
    """GitHub's anchor for a heading."""
    s = heading.strip().lower()
    s = re.sub(r'[^\w\- ]', '', s)
    return s.replace(' ', '-')


def anchors(path):
    text = re.sub(r'^```.*?^```', '', path.read_text(), flags=re.S | re.M)
    seen, out = {}, set()
    for h in re.findall(r'^#{1,6}\s+(.*)$', text, flags=re.M):
        s = slug(h)
        n = seen.get(s, 0)
        out.add(s if n == 0 else '%s-%d' % (s, n))
        seen[s] = n + 1
    return out


def rel(path):
    return str(path.relative_to(ROOT))


def links():
    for doc in DOCS:
        for target in LINK.findall(strip_code(doc.read_text())):
            if re.match(r'[a-z]+:', target):   # http:, https:, mailto:
                continue
            yield doc, target


@pytest.mark.parametrize('doc,target',
                         [pytest.param(d, t, id='%s->%s' % (rel(d), t))
                          for d, t in links()])
def test_every_relative_link_resolves(doc, target):
    file_part, _, anchor = target.partition('#')
    dest = (doc.parent / file_part).resolve() if file_part else doc
    assert dest.exists(), '%s links to %s: no such file' % (rel(doc), target)
    if anchor and dest.suffix == '.md':
        assert anchor in anchors(dest), (
            '%s links to %s: no heading with that anchor in %s'
            % (rel(doc), target, rel(dest)))


@pytest.mark.parametrize('doc', DOCS, ids=rel)
def test_no_words_of_the_projects_history(doc):
    bad = ['%d: %s' % (i, line.strip())
           for i, line in enumerate(doc.read_text().splitlines(), 1)
           if HISTORY.search(line)]
    assert not bad, '%s speaks of the project\'s history:\n%s' % (
        rel(doc), '\n'.join(bad))


def test_the_readme_links_every_guide_page():
    readme = (ROOT / 'README.md').read_text()
    missing = [rel(p) for p in GUIDE if rel(p) not in readme]
    assert GUIDE and not missing, missing


def test_the_reading_path_is_short():
    lines = {rel(p): len(p.read_text().splitlines())
             for p in [ROOT / 'README.md'] + GUIDE}
    assert sum(lines.values()) <= READING_PATH_MAX_LINES, lines


def test_the_readme_shows_the_command_ci_runs():
    ci = (ROOT / '.ci' / 'run').read_text()
    assert 'make test' in ci
    assert re.search(r'^\s+make test\b', (ROOT / 'README.md').read_text(),
                     flags=re.M)


def test_figure_3_is_drawn_aligned():
    """Every box line of architecture.md's Figure 3 has its borders in the
    same columns as the box's top line (one character a column)."""
    text = (ROOT / 'docs' / 'architecture.md').read_text()
    block = text.split("## The paper's Figure 3 in the tree")[1]
    block = block.split('```')[1]
    lines = [l for l in block.splitlines() if l.strip()]
    top = next(l for l in lines if '┌' in l)
    corners = [i for i, c in enumerate(top) if c in '┌┐']
    for line in lines[lines.index(top) + 1:]:
        want = '└┘' if '└' in line else '│┼'
        assert all(i < len(line) and line[i] in want for i in corners), (
            'a border is out of its column: %r' % line)
