"""The README's Python quick start runs as written (it is the front door)."""

import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def test_quick_start_runs(tmp_path, monkeypatch):
    block = re.search(r"## Quick start \(Python\)\s+```python\n(.*?)```", README.read_text(), re.S).group(1)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("GEOGAIT_CACHE", str(tmp_path / "cache"))
    namespace = {}
    exec(compile(block, "README quick start", "exec"), namespace)
    assert (tmp_path / "model.npz").is_file()
    assert namespace["result"].log["ceiling_fraction"].iloc[-1] > 0.5


def test_readme_starts_with_make_demo_then_make_test():
    text = README.read_text()
    assert text.index("make demo") < text.index("make test") < text.index("## Quick start")
