"""Checks of a built site that the build's own warnings miss.

* **Dead internal links**: every relative ``href`` and ``src`` must reach a file, and every ``#fragment``
  an element id of the page it names. External links (``http:``, ``https:``, ``mailto:``) are not fetched.
* **Markup printed as text**: a Sphinx role (``:class:`...```, ``:math:`...```) or directive
  (``.. math::``) outside code blocks is markup that did not render.
* **Built-in docstrings**: the docstring of ``float``, ``tuple`` or another built-in type shown for an
  attribute or a constant that has none of its own, or of a method inherited from one
  (``with_traceback``).

Run after the build (``make docs``)::

    python docs/check_site.py site

Prints one line per finding (the page, what, why) and exits 1 when there is any.
"""

from __future__ import annotations

import re
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

EXTERNAL = ("http", "https", "mailto", "data", "javascript", "ftp")
#: Markup that should have rendered: a role with its backquote, or a directive.
RAW_MARKUP = re.compile(r":(?:class|func|meth|attr|mod|data|obj|math|ref|doc|exc|term):`|^\s*\.\. [a-z-]+::", re.M)
def _opening(docstring: str) -> str:
    """The first 40 characters a page shows of ``docstring`` (autodoc drops a leading "name(args) --" line)."""
    return next(line.strip() for line in docstring.splitlines() if line.strip() and not line.endswith("--"))[:40]


#: Opening words of the docstrings of built-in types and of the methods that subclasses inherit from them.
BUILT_IN_DOCSTRINGS = tuple(_opening(thing.__doc__) for thing in (
    float, int, str, tuple, list, dict, bool, object,
    BaseException.with_traceback, BaseException.add_note, tuple.count, tuple.index))
_VERBATIM = {"pre", "code", "script", "style", "textarea"}


class _Page(HTMLParser):
    """The links, element ids and running text (outside code) of one HTML page."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.links: list[str] = []
        self.ids: set[str] = set()
        self.text: list[str] = []
        self._verbatim = 0

    def handle_endtag(self, tag):
        if tag in _VERBATIM and self._verbatim:
            self._verbatim -= 1

    def handle_data(self, data):
        if not self._verbatim:
            self.text.append(data)

    def handle_starttag(self, tag, attrs):
        self._verbatim += tag in _VERBATIM
        values = dict(attrs)
        for name in ("id", "name"):
            if values.get(name) and (name == "id" or tag == "a"):
                self.ids.add(values[name])
        for name in ("href", "src"):
            if values.get(name) is not None and not (tag == "link" and values.get("rel") == "preconnect"):
                self.links.append(values[name])


def _read(path: Path) -> _Page:
    page = _Page()
    page.feed(path.read_text(encoding="utf-8", errors="replace"))
    return page


def _pages(site: Path) -> dict:
    return {path: _read(path) for path in sorted(site.rglob("*.html"))
            if "_static" not in path.relative_to(site).parts}  # (the theme's template fragments, not pages)


def dead_links(site) -> list[str]:
    """One line per dead link of the built site in ``site``: ``page: link (why)``."""
    site = Path(site).resolve()
    pages = _pages(site)
    dead = []
    for path, page in pages.items():
        for link in page.links:
            why = _why_dead(site, path, link, pages)
            if why:
                dead.append(f"{path.relative_to(site)}: {link} ({why})")
    return dead


def unrendered(site) -> list[str]:
    """One line per piece of markup printed as text, or built-in docstring, in the built site in ``site``."""
    site = Path(site).resolve()
    found = []
    for path, page in _pages(site).items():
        text = "".join(page.text)
        for match in RAW_MARKUP.finditer(text):
            found.append(f"{path.relative_to(site)}: {match.group().strip()!r} (markup printed as text)")
        for opening in BUILT_IN_DOCSTRINGS:
            if opening in text:
                found.append(f"{path.relative_to(site)}: {opening!r} (a built-in's docstring)")
    return found


def _why_dead(site: Path, page: Path, link: str, pages: dict) -> str | None:
    parts = urlsplit(link)
    if parts.scheme in EXTERNAL or link.startswith("//"):
        return None
    if parts.scheme:
        return f"unknown scheme {parts.scheme!r}"
    target = page if not parts.path else (page.parent / unquote(parts.path)).resolve()
    if target.is_dir():
        target = target / "index.html"
    if not target.is_relative_to(site):
        return "outside the site"
    if not target.is_file():
        return "no such file"
    fragment = unquote(parts.fragment)
    if fragment and target.suffix == ".html":
        ids = pages[target].ids if target in pages else _read(target).ids
        if fragment not in ids:
            return f"no element with id {fragment!r} in {target.relative_to(site)}"
    return None


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1 or not Path(argv[0]).is_dir():
        print("usage: python docs/check_site.py SITE_FOLDER (a built site)", file=sys.stderr)
        return 1
    dead, raw = dead_links(argv[0]), unrendered(argv[0])
    for line in dead + raw:
        print(line)
    print(f"{len(dead)} dead internal link(s), {len(raw)} unrendered markup or built-in docstring(s) in {argv[0]}",
          file=sys.stderr if dead or raw else sys.stdout)
    return 1 if dead or raw else 0


if __name__ == "__main__":
    sys.exit(main())
