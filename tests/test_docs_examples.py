"""The Python examples in docs/*.md run as doctests, so that they cannot drift from the code.

Every ```python block in the pages must be a ``>>>`` session: each line is a ``>>>`` or ``...``
line or output that follows one, with no blank line between (doctest would take a line after a
blank one for prose and not run it), and ``>>>`` appears nowhere else in the pages. Each page's
sessions then run in order, sharing one namespace, with ELLIPSIS and NORMALIZE_WHITESPACE on:
floats from a simulation are printed rounded (or end in ``...``), and long output may be wrapped.
An example too slow for the suite marks its slow lines ``# doctest: +SKIP``.

Only the lines inside the python blocks are parsed: the prose and the fences are blanked (a closing
fence right after the output would otherwise be read as more output), so the line numbers in a
failure's report are the page's own. The pages are therefore run by this file, not by
``python -m doctest``.
"""

from __future__ import annotations

import doctest
import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"
PAGES = sorted(DOCS.glob("*.md"))
FENCE = re.compile(r"^[ \t]*(?P<fence>`{3,}|~{3,})[ \t]*(?P<info>[^`\s]*)")
PYTHON_INFO = {"python", "py", "python3", "pycon"}
OPTIONS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def code_blocks(text: str) -> list[tuple[str, int, list[str]]]:
    """The fenced blocks of a Markdown text: (info string, line number of the first line inside
    the block, counting from 1, the block's lines)."""
    blocks, open_fence = [], None
    for number, line in enumerate(text.splitlines(), start=1):
        match = FENCE.match(line)
        if open_fence is None:
            if match:
                open_fence, info, first, lines = match["fence"], match["info"].lower(), number + 1, []
        elif match and match["fence"][0] == open_fence[0] and len(match["fence"]) >= len(open_fence) \
                and not match["info"]:
            blocks.append((info, first, lines))
            open_fence = None
        else:
            lines.append(line)
    if open_fence is not None:
        blocks.append((info, first, lines))  # unclosed: runs to the end of the page
    return blocks


def python_blocks(text: str) -> list[tuple[int, list[str]]]:
    return [(first, lines) for info, first, lines in code_blocks(text) if info in PYTHON_INFO]


def session_problems(page: Path) -> list[str]:
    """Why the page's python blocks are not all ``>>>`` sessions, and where ``>>>`` is outside them."""
    text = page.read_text(encoding="utf-8")
    problems, inside = [], set()
    for first, lines in python_blocks(text):
        inside.update(range(first, first + len(lines)))
        if not any(line.lstrip().startswith(">>>") for line in lines):
            problems.append(f"{page.name}:{first - 1}: a ```python block with no >>> lines (write it as a session)")
            continue
        after_blank = True
        for number, line in enumerate(lines, start=first):
            if not line.strip():
                after_blank = True
                continue
            if after_blank and not line.lstrip().startswith(">>>"):
                problems.append(f"{page.name}:{number}: not part of a >>> session (not run): {line.strip()!r}")
            after_blank = False
    for number, line in enumerate(text.splitlines(), start=1):
        if number not in inside and line.lstrip().startswith(">>>"):
            problems.append(f"{page.name}:{number}: a >>> line outside a ```python block: {line.strip()!r}")
    return problems


def doctest_text(text: str) -> str:
    """The page with every line outside its python blocks blanked, line numbers kept."""
    kept = {}
    for first, lines in python_blocks(text):
        kept.update(zip(range(first, first + len(lines)), lines))
    return "\n".join(kept.get(number, "") for number in range(1, len(text.splitlines()) + 1)) + "\n"


PAGES_WITH_EXAMPLES = [page for page in PAGES
                       if python_blocks(page.read_text(encoding="utf-8")) or ">>>" in page.read_text(encoding="utf-8")]


def test_the_docs_have_examples():
    assert PAGES, f"no Markdown pages found in {DOCS}"
    assert PAGES_WITH_EXAMPLES, f"no ```python block found in {DOCS}/*.md"


def test_code_block_parser():
    text = "prose\n```python\n>>> 1 + 1\n2\n```\n\n````\n```python\nnot python\n```\n````\n```bash\nls\n```\n"
    assert code_blocks(text) == [("python", 3, [">>> 1 + 1", "2"]), ("", 8, ["```python", "not python", "```"]),
                                 ("bash", 13, ["ls"])]
    assert doctest_text(text).splitlines()[1:4] == ["", ">>> 1 + 1", "2"]


@pytest.mark.parametrize("page", PAGES, ids=lambda page: page.name)
def test_every_python_block_is_a_doctest_session(page):
    problems = session_problems(page)
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("page", PAGES_WITH_EXAMPLES, ids=lambda page: page.name)
def test_examples_print_what_the_page_shows(page):
    text = doctest_text(page.read_text(encoding="utf-8"))
    test = doctest.DocTestParser().get_doctest(text, {"__name__": f"docs.{page.stem}"}, page.name, str(page), 0)
    assert test.examples, f"{page.name}: no >>> examples"
    report = []
    result = doctest.DocTestRunner(optionflags=OPTIONS).run(test, out=report.append)
    assert result.failed == 0, f"{page.name}: {result.failed} of {result.attempted} examples failed\n" + "".join(report)
