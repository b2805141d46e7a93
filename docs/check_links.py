"""Dead internal links in a built site: every relative ``href`` and ``src`` must reach a file, and every
``#fragment`` an element id of the page it names.

Run after the build (``make docs``)::

    python docs/check_links.py site

Prints one line per dead link (the page, the link, why) and exits 1 when there is any; external links
(``http:``, ``https:``, ``mailto:``) are not fetched.
"""

from __future__ import annotations

import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

EXTERNAL = ("http", "https", "mailto", "data", "javascript", "ftp")


class _Page(HTMLParser):
    """The links and element ids of one HTML page."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.links: list[str] = []
        self.ids: set[str] = set()

    def handle_starttag(self, tag, attrs):
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


def dead_links(site) -> list[str]:
    """One line per dead link of the built site in ``site``: ``page: link (why)``."""
    site = Path(site).resolve()
    pages = {path: _read(path) for path in sorted(site.rglob("*.html"))
             if "_static" not in path.relative_to(site).parts}  # (the theme's template fragments, not pages)
    dead = []
    for path, page in pages.items():
        for link in page.links:
            why = _why_dead(site, path, link, pages)
            if why:
                dead.append(f"{path.relative_to(site)}: {link} ({why})")
    return dead


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
        print("usage: python docs/check_links.py SITE_FOLDER (a built site)", file=sys.stderr)
        return 1
    dead = dead_links(argv[0])
    for line in dead:
        print(line)
    print(f"{len(dead)} dead internal link(s) in {argv[0]}", file=sys.stderr if dead else sys.stdout)
    return 1 if dead else 0


if __name__ == "__main__":
    sys.exit(main())
