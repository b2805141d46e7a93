"""Code on the site's pages runs as written: the home page's quick start."""

import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[2] / "docs"


@pytest.mark.slow  # (a 40-cycle optimisation and its ceiling)
def test_the_home_pages_quick_start_runs(tmp_path, monkeypatch, capsys):
    block = re.search(r"## Quick start\s.*?```python\n(.*?)```", (DOCS / "index.md").read_text(), re.S).group(1)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("GEOGAIT_CACHE", str(tmp_path / "cache"))
    namespace = {}
    exec(compile(block, "docs/index.md quick start", "exec"), namespace)
    assert namespace["result"].log["ceiling_fraction"].iloc[-1] > 0.5
    assert "held-out Γ" in capsys.readouterr().out


def test_every_page_the_tutorials_include_exists():
    """The tutorials show the templates through literalinclude: the files and the objects they name exist."""
    for page in (DOCS / "tutorials").glob("*.md"):
        for path, name in re.findall(r"```\{literalinclude\} (\S+)\n:pyobject: (\w+)", page.read_text()):
            source = (page.parent / path).resolve()
            assert source.is_file(), f"{page.name}: {path}"
            assert re.search(rf"^(class|def) {name}\b", source.read_text(), re.M), f"{page.name}: {name}"
