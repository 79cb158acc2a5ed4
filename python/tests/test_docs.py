"""Every Python block of the README and the user guide (docs/*.md) runs, as a reader would run
it: the blocks of a page one after the other in one namespace (as cells of a notebook), from
a scratch copy of the repository's data/ and models/. A block preceded by
`<!-- not run: REASON -->` is skipped (cli/tests/docs.rs checks that the reason is given)."""

import os
import re
import shutil
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
FENCE = re.compile(r"^```(\w*)\s*$")


def python_blocks(page):
    """The runnable Python blocks of a page, with the line of each opening fence."""
    lines = page.read_text(encoding="utf-8").splitlines()
    blocks, i = [], 0
    while i < len(lines):
        match = FENCE.match(lines[i])
        if not match:
            i += 1
            continue
        start, j = i, i + 1
        while j < len(lines) and lines[j].strip() != "```":
            j += 1
        before = next((lines[k].strip() for k in range(start - 1, -1, -1) if lines[k].strip()), "")
        if match.group(1) == "python" and not before.startswith("<!-- not run:"):
            blocks.append((start + 1, "\n".join(lines[start + 1 : j]) + "\n"))
        i = j + 1
    return blocks


PAGES_WITH_PYTHON = [p for p in PAGES if python_blocks(p)]


def test_the_guide_has_python_to_run():
    names = {p.name for p in PAGES_WITH_PYTHON}
    assert {"README.md", "python.md"} <= names, names


@pytest.mark.parametrize("page", PAGES_WITH_PYTHON, ids=lambda p: p.relative_to(REPO).as_posix())
def test_python_blocks_run(page, tmp_path, monkeypatch):
    import matplotlib

    matplotlib.use("Agg")
    for tree in ("data", "models"):
        shutil.copytree(REPO / tree, tmp_path / tree)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    namespace = {"__name__": "__docs__"}
    for line, code in python_blocks(page):
        where = f"{page.relative_to(REPO)}:{line}"
        try:
            exec(compile(code, where, "exec"), namespace)
        except Exception as e:  # the page and line of the block, then the error
            raise AssertionError(f"{where}: the block failed: {e!r}") from e
    import matplotlib.pyplot as plt

    plt.close("all")
    assert os.getcwd() == str(tmp_path)
