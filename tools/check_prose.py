"""Hold the user docs to the project's prose rules.

Every user page (``README.md`` and ``docs/**/*.md``; not ``CHANGELOG.md``, and not a page a benchmark writes
beside its JSON manifest, such as ``robots.md`` next to ``robots.json``) must have:

* a median sentence of at most 25 words (tables and code blocks are not sentences);
* at most 6 numbers in a prose paragraph (each list item is a paragraph; tables carry the numbers);
* at most 60 words in a table cell;
* no private module named (a dotted or slashed path with a part that starts with one underscore, such as
  ``geogait.robots._bridge`` or ``robots/_bridge.py``);
* no relative link to a file that does not exist.

Run ``python tools/check_prose.py`` from the repository root: it prints one line per problem and exits 1 when
there is any.
"""

from __future__ import annotations

import re
import statistics
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MAX_MEDIAN_SENTENCE = 25
MAX_NUMBERS = 6
MAX_CELL_WORDS = 60

FENCE = re.compile(r"^\s*(```|~~~)")
COMMENT = re.compile(r"<!--.*?-->", re.S)
LIST_ITEM = re.compile(r"^\s*(?:[*+-]|\d+[.)])\s+")
LINK = re.compile(r"!?\[((?:[^\[\]]|\[[^\]]*\])*)\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
INLINE_CODE = re.compile(r"`[^`]*`")
NUMBER = re.compile(r"(?<![\w.])[−+-]?\d+(?:[.,]\d+)*(?:[eE][−+-]?\d+)?(?![\w])")
PRIVATE_MODULE = re.compile(r"\b[A-Za-z]\w*(?:[./][A-Za-z_]\w*)*[./]_[A-Za-z]\w*")
ABBREVIATIONS = re.compile(r"\b(?:e\.g|i\.e|cf|vs|etc|Fig|Figs|Eq|eq|Eqs|No|approx|resp|al)\.", re.I)
SENTENCE_END = re.compile(r"(?<=[.!?])[\"')\]*_]*\s+(?=[\"'(\[*_`]*[A-Z0-9ΓξθφΔ])")


@dataclass(frozen=True)
class Problem:
    path: str
    line: int
    message: str

    def __str__(self) -> str:
        return f"{self.path}:{self.line}: {self.message}"


def user_pages(root: Path = ROOT) -> list[Path]:
    """README.md and every docs page, less those a benchmark writes beside its manifest."""
    pages = [root / "README.md", *sorted((root / "docs").rglob("*.md"))]
    return [page for page in pages if page.is_file() and not page.with_suffix(".json").is_file()]


def blocks(text: str) -> list[tuple[int, str, list[str]]]:
    """The page cut into (first line number, kind, lines); kind is 'prose', 'table', 'heading' or 'code'."""
    text = COMMENT.sub(lambda m: "\n" * m.group().count("\n"), text)
    out: list[tuple[int, str, list[str]]] = []
    current: list[str] = []
    kind, start, in_code = "prose", 0, False

    def close() -> None:
        if current:
            out.append((start, kind, list(current)))
            current.clear()

    for number, line in enumerate(text.splitlines(), 1):
        if FENCE.match(line):
            if in_code:
                current.append(line)
                close()
                in_code, kind = False, "prose"
                continue
            close()
            in_code, kind, start = True, "code", number
            current.append(line)
            continue
        if in_code:
            current.append(line)
            continue
        stripped = line.strip()
        line_kind = "table" if stripped.startswith("|") else "heading" if stripped.startswith("#") else "prose"
        starts_item = bool(LIST_ITEM.match(line))
        if not stripped or line_kind != kind or line_kind == "heading" or (starts_item and line_kind == "prose"):
            close()
        if stripped:
            if not current:
                kind, start = line_kind, number
            current.append(line)
    close()
    return out


def plain(text: str) -> str:
    """Prose as read: a link is its text, an image and inline code are one word, emphasis marks dropped."""
    text = re.sub(r"!\[[^\]]*\]\([^)]*\)", " ", text)
    text = LINK.sub(lambda m: m.group(1), text)
    text = INLINE_CODE.sub("code", text)
    text = LIST_ITEM.sub("", text)
    return re.sub(r"[*_]{1,3}(?=\S)|(?<=\S)[*_]{1,3}", "", text)


def sentences(paragraph: str) -> list[str]:
    """A prose paragraph's sentences (abbreviations such as 'e.g.' and 'Fig.' do not end one)."""
    text = " ".join(plain(paragraph).split())
    text = ABBREVIATIONS.sub(lambda m: m.group().replace(".", "\0"), text)
    return [part.replace("\0", ".") for part in SENTENCE_END.split(text) if part.split()]


def numbers(paragraph: str) -> list[str]:
    """The numbers a reader meets in a prose paragraph; those inside inline code and link targets are not."""
    text = LINK.sub(lambda m: m.group(1), paragraph)
    text = LIST_ITEM.sub("", INLINE_CODE.sub(" ", text))
    return NUMBER.findall(text)


def table_cells(lines: list[str]) -> list[str]:
    cells: list[str] = []
    for line in lines:
        cells.extend(cell for cell in re.split(r"(?<!\\)\|", line.strip().strip("|")))
    return cells


#: Folders of the site that the docs build writes (sphinx-gallery's examples).
GENERATED = ("auto_examples",)


def link_problems(path: Path, lines: list[str], start: int, root: Path) -> list[Problem]:
    problems = []
    for offset, line in enumerate(lines):
        for match in LINK.finditer(INLINE_CODE.sub(" ", line)):
            target = match.group(2).split("#", 1)[0]
            if not target or re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I):
                continue
            generated = target.split("/", 1)[0] in GENERATED  # (made by the site build: its own check covers it)
            if not generated and not (path.parent / target).exists():
                problems.append(Problem(_name(path, root), start + offset, f"link to a missing file: {target}"))
    return problems


def check_page(path: Path, root: Path = ROOT) -> list[Problem]:
    """Every rule broken on one page, each with its line."""
    name = _name(path, root)
    problems: list[Problem] = []
    lengths: list[int] = []
    for start, kind, lines in blocks(path.read_text(encoding="utf-8")):
        if kind == "code":
            continue
        problems += link_problems(path, lines, start, root)
        text = "\n".join(lines)
        for match in PRIVATE_MODULE.finditer(LINK.sub(lambda m: m.group(1), text)):
            problems.append(Problem(name, start, f"names a private module: {match.group()}"))
        if kind == "table":
            for cell in table_cells(lines):
                words = len(plain(cell).split())
                if words > MAX_CELL_WORDS:
                    problems.append(Problem(name, start, f"a table cell of {words} words (at most {MAX_CELL_WORDS})"))
        elif kind == "prose":
            found = numbers(text)
            if len(found) > MAX_NUMBERS:
                message = f"{len(found)} numbers in one paragraph (at most {MAX_NUMBERS}; tables carry numbers)"
                problems.append(Problem(name, start, message))
            lengths += [len(sentence.split()) for sentence in sentences(text)]
    if lengths and statistics.median(lengths) > MAX_MEDIAN_SENTENCE:
        problems.append(
            Problem(name, 1, f"median sentence of {statistics.median(lengths):g} words (at most {MAX_MEDIAN_SENTENCE})")
        )
    return problems


def _name(path: Path, root: Path) -> str:
    try:
        return str(path.relative_to(root))
    except ValueError:
        return str(path)


def main(argv: list[str] | None = None) -> int:
    pages = [Path(arg).resolve() for arg in argv] if argv else user_pages()
    problems = [problem for page in pages for problem in check_page(page)]
    for problem in problems:
        print(problem)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
