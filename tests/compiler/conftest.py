"""Fixtures of the compiler tests (the session-wide ones are in tests/conftest.py)."""

from __future__ import annotations

import shutil
from types import SimpleNamespace

import pytest

from tests.support import EXAMPLES

#: the line that makes planet-sort's `at` untraceable: a branch on the state
BRANCH = "  if m.pz > 2.0 then return False() end\n"


@pytest.fixture(scope="session")
def untraceable_sort(tmp_path_factory):
    """examples/planet-sort copied with `at` made untraceable (BRANCH after its first line):
    ``lua`` (the edited file), ``world`` (opened) and ``fallback`` (its CompiledProgram, `at` a
    `lua` node). Read only."""
    from tmpc.compiler.artifact import open_world
    from tmpc.compiler.compile import CompiledProgram, compile_world, external_predicates
    ex = tmp_path_factory.mktemp("lua-fb") / "ps"
    shutil.copytree(EXAMPLES / "planet-sort", ex)
    lua = ex / "sort.lua"
    text = lua.read_text()
    head = text.index("\n", text.index("function at(")) + 1
    lua.write_text(text[:head] + BRANCH + text[head:])
    world = open_world(ex / "sort.toml")
    fallback = CompiledProgram(world.program, world.scene, compile_world(world).model,
                               external=external_predicates(world.config.semantics, world.program))
    return SimpleNamespace(lua=lua, world=world, fallback=fallback)
