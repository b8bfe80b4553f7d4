"""Every Python code block of docs/api.md and of the README's "Python" section runs, in order,
in one namespace per file, from the repository's root: the documented API cannot go stale."""

from __future__ import annotations

import re

import pytest

from tests.support import ROOT

BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def python_blocks(text: str) -> list[str]:
    return BLOCK.findall(text)


def readme_python_section() -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    return text.split("\n## Python\n", 1)[1].split("\n## ", 1)[0]


def test_blocks_are_found():
    assert len(python_blocks((ROOT / "docs" / "api.md").read_text(encoding="utf-8"))) >= 5
    assert len(python_blocks(readme_python_section())) == 1
    assert python_blocks("```python\nx = 1\n```\n") == ["x = 1\n"]


@pytest.mark.parametrize("source", ["docs/api.md", "README.md"])
def test_every_code_block_runs(source, monkeypatch, capsys):
    monkeypatch.chdir(ROOT)
    text = (ROOT / source).read_text(encoding="utf-8")
    blocks = python_blocks(readme_python_section() if source == "README.md" else text)
    namespace: dict = {"__name__": "__docs__"}
    for i, block in enumerate(blocks):
        try:
            exec(compile(block, f"{source}[python block {i + 1}]", "exec"), namespace)
        except Exception as exc:   # noqa: BLE001 - which block, then the error
            raise AssertionError(f"{source}, Python block {i + 1} fails: {exc!r}\n{block}") \
                from exc
