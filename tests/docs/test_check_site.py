"""The checks of the built site (docs/check_site.py): dead links, markup printed as text, built-in docstrings."""

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("check_site", ROOT / "docs" / "check_site.py")
check_site = importlib.util.module_from_spec(spec)
spec.loader.exec_module(check_site)


@pytest.fixture
def site(tmp_path):
    (tmp_path / "guide").mkdir()
    (tmp_path / "index.html").write_text(
        '<a href="guide/page.html#usage">ok</a> <a href="https://example.org/missing">external</a>'
        '<img src="figure.png"> <a href="#top" id="top">self</a> <a href="guide/">folder</a>')
    (tmp_path / "figure.png").write_bytes(b"png")
    (tmp_path / "guide" / "index.html").write_text("<p>guide</p>")
    (tmp_path / "guide" / "page.html").write_text(
        '<h2 id="usage">Usage</h2><a href="../index.html">home</a><p>Uses <code>:class:`Robot`</code> in code.</p>'
        '<pre>.. math:: x = 1\n:math:`y`</pre><p>A <span class="math">\\(\\xi\\)</span> rendered.</p>')
    return tmp_path


def test_a_site_whose_links_all_resolve_passes(site, capsys):
    assert check_site.dead_links(site) == []
    assert check_site.main([str(site)]) == 0


@pytest.mark.parametrize(("link", "why"), [
    ("missing.html", "no such file"),
    ("page.html#install", "no element with id 'install' in guide/page.html"),
    ("#nowhere", "no element with id 'nowhere' in guide/page.html"),
    ("../../examples/robot.py", "outside the site"),
    ("../examples/robot.py", "no such file"),
    ("../index.html#usage", "no element with id 'usage' in index.html"),
])
def test_each_dead_link_is_named_with_its_page_and_reason(site, link, why, capsys):
    page = site / "guide" / "page.html"
    page.write_text(page.read_text() + f'<a href="{link}">x</a>')
    assert check_site.dead_links(site) == [f"guide/page.html: {link} ({why})"]
    assert check_site.main([str(site)]) == 1
    assert "1 dead internal link(s), 0 unrendered" in capsys.readouterr().err


def test_a_missing_site_folder_is_a_usage_error(tmp_path, capsys):
    assert check_site.main([str(tmp_path / "nothing")]) == 1
    assert "usage" in capsys.readouterr().err


@pytest.mark.parametrize(("html", "finding"), [
    ("<p>See :class:`~geogait.robots.Robot` for more.</p>", "':class:`' (markup printed as text)"),
    ("<dd>with :math:`A(r)` the connection</dd>", "':math:`' (markup printed as text)"),
    ("<div>\n.. math:: \\xi = -A(r) \\dot r\n</div>", "'.. math::' (markup printed as text)"),
    ("<dd><p>Convert a string or number to a floating point number, if possible.</p></dd>",
     "'Convert a string or number to a floating' (a built-in's docstring)"),
    ("<dd><p>Built-in immutable sequence.</p></dd>", "'Built-in immutable sequence.' (a built-in's docstring)"),
    ("<dd><p>add a note to the exception</p></dd>", "'add a note to the exception' (a built-in's docstring)"),
])
def test_markup_printed_as_text_and_built_in_docstrings_are_found(site, html, finding, capsys):
    (site / "guide" / "api.html").write_text(html)
    assert check_site.unrendered(site) == [f"guide/api.html: {finding}"]
    assert check_site.main([str(site)]) == 1
    assert "0 dead internal link(s), 1 unrendered" in capsys.readouterr().err


def test_code_and_rendered_math_are_not_findings(site):
    assert check_site.unrendered(site) == []
