"""The Python page's examples (docs/python.md, where the README's moved), run as written (each
```python block in order, in one namespace, in a fresh folder with the repository's examples/;
the Dask one, which needs a cluster, aside), so that none of them fails the way the first one
did (`NameError: name 'q' is not defined`). crates/cli/tests/python_package.rs runs the same
blocks from cargo test (and leaves this file out)."""

import os
import shutil
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]


def python_blocks():
    blocks, current = [], None
    for line in (ROOT / "docs" / "python.md").read_text(encoding="utf-8").splitlines():
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


def test_every_readme_python_example_runs_as_written(tmp_path):
    # The Dask example needs a cluster's scheduler at its address: test_distributed.py runs
    # the same calls on a LocalCluster.
    blocks = [b for b in python_blocks() if "tcp://scheduler" not in b]
    assert len(blocks) >= 2, blocks
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    here = os.getcwd()
    os.chdir(tmp_path)
    try:
        namespace = {}
        for block in blocks:
            exec(compile(block, "docs/python.md", "exec"), namespace)  # noqa: S102 - the page's own examples
    finally:
        os.chdir(here)
    # What the first block promises: shapes and the inverse pair aba ∘ rnea = identity.
    assert namespace["M"].shape == (4, 4) and namespace["J"].shape == (6, 4)
    assert namespace["tau"].shape == (1000, 4)
    assert np.allclose(namespace["arm"].aba(namespace["q"], namespace["v"], namespace["tau"][0]), 0.0, atol=1e-9)
