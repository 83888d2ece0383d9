"""The examples of docs/python-objects.md, run as written (each ```python block in order, in one
namespace, in a folder with the repository's examples/), so that the page's code works. Once the
page is folded into docs/python.md (whose examples crates/cli/tests/python_package.rs runs), this
checks that the objects are documented there."""

import os
import shutil
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
PAGE = ROOT / "docs" / "python-objects.md"


def python_blocks(path):
    blocks, current = [], None
    for line in path.read_text(encoding="utf-8").splitlines():
        stripped = line.strip()
        if stripped.startswith("```"):
            if current is not None:
                blocks.append("\n".join(current))
                current = None
            elif stripped == "```python":
                current = []
            continue
        if current is not None:
            current.append(line)
    return blocks


def test_every_example_of_the_page_runs(tmp_path):
    if not PAGE.exists():
        folded = (ROOT / "docs" / "python.md").read_text(encoding="utf-8")
        assert "chessarm.Setup" in folded and "chessarm.Simulator" in folded
        return
    blocks = python_blocks(PAGE)
    assert len(blocks) >= 5
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    here = os.getcwd()
    os.chdir(tmp_path)
    try:
        namespace = {}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for block in blocks:
                exec(compile(block, str(PAGE), "exec"), namespace)  # noqa: S102 - the page's own examples
    finally:
        os.chdir(here)
    assert namespace["mine"].t > 12.9  # the own controller's loop ran along the whole plan
