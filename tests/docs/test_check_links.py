"""The dead-link check of the built site (docs/check_links.py)."""

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("check_links", ROOT / "docs" / "check_links.py")
check_links = importlib.util.module_from_spec(spec)
spec.loader.exec_module(check_links)


@pytest.fixture
def site(tmp_path):
    (tmp_path / "guide").mkdir()
    (tmp_path / "index.html").write_text(
        '<a href="guide/page.html#usage">ok</a> <a href="https://example.org/missing">external</a>'
        '<img src="figure.png"> <a href="#top" id="top">self</a> <a href="guide/">folder</a>')
    (tmp_path / "figure.png").write_bytes(b"png")
    (tmp_path / "guide" / "index.html").write_text("<p>guide</p>")
    (tmp_path / "guide" / "page.html").write_text('<h2 id="usage">Usage</h2><a href="../index.html">home</a>')
    return tmp_path


def test_a_site_whose_links_all_resolve_passes(site, capsys):
    assert check_links.dead_links(site) == []
    assert check_links.main([str(site)]) == 0


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
    assert check_links.dead_links(site) == [f"guide/page.html: {link} ({why})"]
    assert check_links.main([str(site)]) == 1
    assert "1 dead internal link(s)" in capsys.readouterr().err


def test_a_missing_site_folder_is_a_usage_error(tmp_path, capsys):
    assert check_links.main([str(tmp_path / "nothing")]) == 1
    assert "usage" in capsys.readouterr().err
