"""Every relative link in README.md and docs/*.md points at a file (or folder) that exists,
and a link's #anchor, where it names a markdown page, at one of that page's headings. Pure
text: a moved or renamed file (a page, a picture, a benchmark's data under
docs/results/data/) cannot leave a dead link behind."""
from __future__ import annotations

import re
import unicodedata
from pathlib import Path
from urllib.parse import unquote

import pytest
from common import REPO

PAGES = sorted([REPO / "README.md", *(REPO / "docs").glob("*.md"), *(REPO / "docs").glob("results/**/*.md")])

# Links known to be dead and left so on purpose, as (page relative to the repository, target):
# none at present. A new entry needs a comment saying why the link cannot be fixed.
KNOWN_DEAD: set[tuple[str, str]] = set()

_FENCE = re.compile(r"^\s*(```|~~~)")
_CODE_SPAN = re.compile(r"(`+)(?:(?!\1).)+?\1")
# the "](target)" or "](target "title")" that ends [text](...) and ![alt](...); matched on
# its own so that a picture inside a link ([![alt](a.png)](b.svg)) gives both targets
_LINK = re.compile(r"\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_REF_DEF = re.compile(r"^\s{0,3}\[[^\]]+\]:\s*<?(\S+?)>?(?:\s+\"[^\"]*\")?\s*$")
_HEADING = re.compile(r"^\s{0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
_SCHEME = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:")


def _prose_lines(text: str, blank_code: bool = True):
    """(line number, line) outside fenced code blocks, inline code spans blanked unless told."""
    fenced = None
    for no, line in enumerate(text.splitlines(), 1):
        m = _FENCE.match(line)
        if m:
            if fenced is None:
                fenced = m.group(1)
            elif m.group(1) == fenced:
                fenced = None
            continue
        if fenced is None:
            yield no, _CODE_SPAN.sub(lambda s: " " * len(s.group(0)), line) if blank_code else line


def links(page: Path) -> list[tuple[int, str]]:
    out = []
    for no, line in _prose_lines(page.read_text(encoding="utf-8")):
        out += [(no, m.group(1)) for m in _LINK.finditer(line)]
        m = _REF_DEF.match(line)
        if m:
            out.append((no, m.group(1)))
    return out


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading: markup dropped, lower case, punctuation but - and _
    removed, spaces to -."""
    h = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link's text
    h = h.replace("`", "").replace("*", "")
    h = unicodedata.normalize("NFC", h).lower()
    h = "".join(c for c in h if c.isalnum() or c in " -_")
    return h.replace(" ", "-")


def anchors(page: Path) -> set[str]:
    seen: dict[str, int] = {}
    out = set()
    for _, line in _prose_lines(page.read_text(encoding="utf-8"), blank_code=False):
        m = _HEADING.match(line)
        if not m:
            continue
        slug = _slug(m.group(2))
        n = seen.get(slug, 0)
        seen[slug] = n + 1
        out.add(slug if n == 0 else f"{slug}-{n}")
    return out


def dead_links(page: Path) -> list[str]:
    bad = []
    own = page.relative_to(REPO).as_posix()
    for no, target in links(page):
        if _SCHEME.match(target) or target.startswith("//"):
            continue  # a web address (http:, https:, mailto:)
        path, _, anchor = target.partition("#")
        dest = (page.parent / unquote(path)).resolve() if path else page
        if (own, target) in KNOWN_DEAD:
            continue
        if not dest.exists():
            bad.append(f"{own}:{no}: {target} (no such file: {dest.relative_to(REPO) if dest.is_relative_to(REPO) else dest})")
        elif anchor and dest.suffix == ".md" and unquote(anchor).lower() not in anchors(dest):
            bad.append(f"{own}:{no}: {target} (no heading #{anchor} in {dest.relative_to(REPO)})")
    return bad


def test_pages_found():
    assert REPO / "README.md" in PAGES and len(PAGES) > 20


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(REPO).as_posix())
def test_relative_links_resolve(page):
    assert not dead_links(page), "dead links:\n" + "\n".join(dead_links(page))


def test_known_dead_links_still_dead():
    """An entry of KNOWN_DEAD whose link was fixed or removed goes from the list."""
    found = {(p.relative_to(REPO).as_posix(), t) for p in PAGES for _, t in links(p)}
    assert not KNOWN_DEAD - found


def test_link_parser():
    text = ("see [a](x.md#b), ![p](img/p.png) and [![q](img/q.png)](img/q.svg) `[c](not/a/link)`\n"
            "```\n[d](in/a/fence)\n```\n[e]: ref/def.json\n")
    found = []
    for no, line in _prose_lines(text):
        found += [t.group(1) for t in _LINK.finditer(line)]
        m = _REF_DEF.match(line)
        if m:
            found.append(m.group(1))
    assert found == ["x.md#b", "img/p.png", "img/q.png", "img/q.svg", "ref/def.json"], found
    assert _slug("The adjoint on the GPU") == "the-adjoint-on-the-gpu"
    assert _slug("Bodies from measurements (`from_measurements`, `seamfit body`)") == \
        "bodies-from-measurements-from_measurements-seamfit-body"
