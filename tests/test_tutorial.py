"""docs/tutorial.md runs as written (issue S): its files are examples/tower's, and every command
of its shell blocks succeeds in a fresh folder holding them."""

from __future__ import annotations

import re
import shlex
import subprocess
import sys

from tests.support import DOCS, EXAMPLES

TUTORIAL = DOCS / "tutorial.md"
BLOCK = re.compile(r"^```(\w+)(?: file=(\S+))?\n(.*?)^```\n", re.M | re.S)


def _blocks():
    return [(m.group(1), m.group(2), m.group(3)) for m in BLOCK.finditer(TUTORIAL.read_text())]


def test_the_tutorial_files_are_the_example():
    files = {path: body for _, path, body in _blocks() if path}
    assert set(files) == {f"tower/{f.name}" for f in (EXAMPLES / "tower").iterdir()}
    for path, body in files.items():
        assert body == (EXAMPLES / path).read_text(), path


def test_every_command_of_the_tutorial_succeeds(tmp_path):
    commands = []
    for lang, path, body in _blocks():
        if path:
            (tmp_path / path).parent.mkdir(parents=True, exist_ok=True)
            (tmp_path / path).write_text(body)
        elif lang == "bash":
            commands += [line for line in body.splitlines() if line.strip()]
    assert commands
    for line in commands:
        argv = shlex.split(line)
        assert argv[0] == "tmpc", line
        out = subprocess.run([sys.executable, "-m", "tmpc.runtime.cli", *argv[1:]],
                             cwd=tmp_path, capture_output=True, text=True, timeout=600)
        assert out.returncode == 0, (line, out.stderr)
    assert (tmp_path / "plan.json").is_file() and (tmp_path / "plan.html").is_file()
