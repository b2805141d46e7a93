"""The user docs keep the prose rules of tools/check_prose.py, and the checker finds what it should."""

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("check_prose", ROOT / "tools" / "check_prose.py")
check_prose = importlib.util.module_from_spec(_spec)
sys.modules["check_prose"] = check_prose
_spec.loader.exec_module(check_prose)


@pytest.mark.parametrize("page", check_prose.user_pages(), ids=lambda page: str(page.relative_to(ROOT)))
def test_user_page_keeps_the_prose_rules(page):
    problems = check_prose.check_page(page)
    assert not problems, "\n".join(map(str, problems))


def test_user_pages_are_readme_and_docs_without_changelog_or_generated_pages():
    pages = {str(page.relative_to(ROOT)) for page in check_prose.user_pages()}
    assert "README.md" in pages and "docs/index.md" in pages
    assert "CHANGELOG.md" not in pages
    assert "docs/results/robots/robots.md" not in pages  # written by benchmarks/robots.py beside robots.json


def _problems(tmp_path, text, name="page.md"):
    page = tmp_path / name
    page.write_text(text, encoding="utf-8")
    return [problem.message for problem in check_prose.check_page(page, root=tmp_path)]


GOOD = """# A good page

The optimiser learns a model while the robot moves. It steps along the model's gradient.
Run `geogait optimize --links 3 --cycles 40 --seed 0 --noise 0.1 --out out/a` to try it.

| robot | 30 | 60 | 100 | 200 | 300 | 400 |
|---|---|---|---|---|---|---|
| 3 links | 99.7 | 99.9 | 99.8 | 99.8 | 99.8 | 99.8 |

```bash
geogait optimize --links 3 --cycles 1 2 3 4 5 6 7 8 9 10 --out out/demo
```

See [the other page](other.md#a-heading), e.g. its second table, and [the paper](https://example.org/x).
"""


def test_a_good_page_passes(tmp_path):
    (tmp_path / "other.md").write_text("# Other\n\nIt is short.\n")
    assert _problems(tmp_path, GOOD) == []


def test_a_long_median_sentence_fails(tmp_path):
    long = " ".join(["word"] * 30) + "."
    problems = _problems(tmp_path, f"# Page\n\n{long} {long} Short one.\n")
    assert problems == ["median sentence of 31 words (at most 25)"]


def test_abbreviations_do_not_end_a_sentence():
    assert len(check_prose.sentences("Fig. 5 shows it, e.g. on 3 links. Then it stops.")) == 2


def test_seven_numbers_in_a_paragraph_fail_and_six_pass(tmp_path):
    assert _problems(tmp_path, "It reached 1, 2, 3, 4, 5 and 6 %.\n") == []
    problems = _problems(tmp_path, "It reached 1, 2.5, 3e-4, −4, 5, 6 and 7 %.\n")
    assert problems == ["7 numbers in one paragraph (at most 6; tables carry numbers)"]


def test_each_list_item_is_its_own_paragraph(tmp_path):
    assert _problems(tmp_path, "* It reached 1, 2, 3 and 4.\n* It reached 5, 6, 7 and 8.\n") == []
    assert len(_problems(tmp_path, "* It reached 1, 2, 3, 4, 5, 6 and 7.\n* Fine.\n")) == 1


def test_numbers_in_inline_code_and_link_targets_do_not_count(tmp_path):
    (tmp_path / "run-1-2-3-4-5-6-7.md").write_text("# Run\n")
    assert _problems(tmp_path, "Run `geogait optimize --links 1 2 3 4 5 6 7`, see [it](run-1-2-3-4-5-6-7.md).\n") == []


def test_a_long_table_cell_fails(tmp_path):
    cell = " ".join(["word"] * 61)
    assert _problems(tmp_path, f"| a | b |\n|---|---|\n| {cell} | x |\n") == ["a table cell of 61 words (at most 60)"]


PRIVATE = ["`geogait.optimize._climb`", "geogait.robots._bridge", "`src/geogait/robots/_bridge.py`"]


@pytest.mark.parametrize("named", PRIVATE)
def test_a_private_module_named_fails(tmp_path, named):
    assert _problems(tmp_path, f"The protocol lives in {named}.\n") == [
        f"names a private module: {named.strip('`').removesuffix('.py')}"
    ]


def test_public_names_with_underscores_pass(tmp_path):
    assert _problems(tmp_path, "Read `model.gamma_` and call `geogait.robots.check_robot` or `__init__.py`.\n") == []


def test_a_private_module_in_a_code_block_passes(tmp_path):
    assert _problems(tmp_path, "# Page\n\n```python\nfrom geogait.robots._bridge import x\n```\n") == []


def test_a_dead_relative_link_fails_and_an_anchor_or_url_passes(tmp_path):
    problems = _problems(tmp_path, "See [here](missing.md), [there](#top) and [web](https://example.org/missing.md).\n")
    assert problems == ["link to a missing file: missing.md"]


def test_main_exits_1_on_a_problem_and_0_without(tmp_path, capsys):
    bad, good = tmp_path / "bad.md", tmp_path / "good.md"
    bad.write_text("See [here](missing.md).\n")
    good.write_text("It is fine.\n")
    assert check_prose.main([str(bad)]) == 1
    assert "link to a missing file" in capsys.readouterr().out
    assert check_prose.main([str(good)]) == 0


def test_readme_stays_a_short_front_door():
    assert (ROOT / "README.md").stat().st_size <= 12_000
