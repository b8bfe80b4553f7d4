"""Prose that is checked: every Sphinx-style reference (``:mod:``, ``:func:``, ``:class:``,
``:meth:``, ``:attr:``) in the source's docstrings and comments (lang/, compiler/, runtime/,
stdlib/) and in docs/*.md and README.md names something that exists, and every citation of
``docs/design.md`` §x or ``docs/math.md`` §y names a section of that file.

A reference resolves when it is a fully-qualified ``tmpc.`` name (imported, then its attributes
looked up), or a short name in the namespace of the module it is written in (what the module
defines or imports), or an attribute of a class of that module (``:meth:`dist``` in a method's
docstring). An attribute counts when the class (or a base) has it, annotates it, or assigns
``self.<name>`` in its source.
"""

from __future__ import annotations

import builtins
import importlib
import inspect
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("lang", "compiler", "runtime", "stdlib")
ROLE = re.compile(r":(mod|func|class|meth|attr|data|obj|exc):`([^`]+)`")
CITATION = re.compile(r"docs/(design|math)\.md §\s?([0-9A-Za-z.]*[0-9A-Za-z])")


def module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] in ("__init__", "__main__"):
        parts.pop()
    return ".".join(["tmpc", *parts])


def prose_files() -> list[Path]:
    files = [p for layer in LAYERS for p in sorted((ROOT / layer).rglob("*.py"))]
    return files + sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md"]


def references(path: Path) -> list[tuple[int, str, str]]:
    text = path.read_text(encoding="utf-8")
    out = []
    for m in ROLE.finditer(text):
        line = text.count("\n", 0, m.start()) + 1
        out.append((line, m.group(1), m.group(2)))
    return out


def _target(text: str) -> str:
    name = re.sub(r"\s+", "", text)
    if "<" in name and name.endswith(">"):          # :func:`title <target>`
        name = name[name.index("<") + 1:-1]
    return name.lstrip("~!").removesuffix("()")


def _has_attr(obj, name: str) -> bool:
    if hasattr(obj, name):
        return True
    if inspect.isclass(obj):
        for klass in obj.__mro__:
            if name in getattr(klass, "__annotations__", {}) or \
                    name in (getattr(klass, "__slots__", ()) or ()):
                return True
            try:
                src = inspect.getsource(klass)
            except (OSError, TypeError):
                continue
            if re.search(rf"\bself\.{re.escape(name)}\s*(:[^=\n]*)?=(?!=)", src):
                return True
    return False


def _walk(obj, parts: list[str]) -> bool:
    for i, part in enumerate(parts):
        if not _has_attr(obj, part):
            return False
        if i < len(parts) - 1:
            obj = getattr(obj, part, None)
            if obj is None:
                return False
    return True


def _resolve_qualified(name: str) -> bool:
    parts = name.split(".")
    for k in range(len(parts), 0, -1):
        try:
            mod = importlib.import_module(".".join(parts[:k]))
        except ImportError:
            continue
        return _walk(mod, parts[k:])
    return False


def resolves(name: str, home: str | None) -> bool:
    """Whether ``name`` (a reference's target) exists, read from module ``home`` (None: docs)."""
    if name.startswith("tmpc."):
        return _resolve_qualified(name)
    if name.startswith("."):
        return False                    # relative names are how the old flat layout was named
    if "." not in name and hasattr(builtins, name):
        return True
    if home is None:
        return False
    mod = importlib.import_module(home)
    parts = name.split(".")
    if _walk(mod, parts):
        return True
    classes = [v for v in vars(mod).values()
               if inspect.isclass(v) and getattr(v, "__module__", None) == mod.__name__]
    return any(_walk(c, parts) for c in classes)


#: Files other helpers own while issue P's parts are written in parallel: their stale names are
#: listed in the report for the coordinator, who empties this set after merging.
NOT_YET: set[str] = set()


def stale_references() -> list[str]:
    bad = []
    for path in prose_files():
        if str(path.relative_to(ROOT)) in NOT_YET:
            continue
        home = module_name(path) if path.suffix == ".py" else None
        for line, role, text in references(path):
            if not resolves(_target(text), home):
                bad.append(f"{path.relative_to(ROOT)}:{line}: :{role}:`{text}`")
    return bad


def sections(doc: Path) -> set[str]:
    """Section ids of a numbered Markdown document: ``## 6.`` / ``### 6.3`` / ``#### C.3b``."""
    ids = set()
    for line in doc.read_text(encoding="utf-8").splitlines():
        m = re.match(r"#+\s+([0-9A-Z](?:\.[0-9a-z]+)*[a-z]?)\.?\s", line)
        if m:
            ids.add(m.group(1))
    return ids


def cited_files() -> list[Path]:
    files = [p for layer in LAYERS for p in sorted((ROOT / layer).rglob("*"))
             if p.suffix in (".py", ".lua", ".tmpc", ".lark")]
    files += sorted((ROOT / "docs").rglob("*.md")) + [ROOT / "README.md", ROOT / "pyproject.toml"]
    return files + sorted((ROOT / "tests").rglob("*.py"))


def bad_citations() -> list[str]:
    known = {d: sections(ROOT / "docs" / f"{d}.md") for d in ("design", "math")}
    bad = []
    for path in cited_files():
        text = path.read_text(encoding="utf-8")
        for m in CITATION.finditer(text):
            if m.group(2) not in known[m.group(1)]:
                line = text.count("\n", 0, m.start()) + 1
                bad.append(f"{path.relative_to(ROOT)}:{line}: {m.group(0)}")
    return bad


def test_every_reference_in_the_prose_resolves():
    bad = stale_references()
    assert not bad, "references to nothing (use a tmpc.-qualified name or one of the module's " \
                    "own names):\n" + "\n".join(bad)


def test_every_citation_of_the_design_and_math_docs_names_a_section():
    bad = bad_citations()
    assert not bad, "citations of sections that do not exist:\n" + "\n".join(bad)


def test_the_section_reader_sees_the_numbering():
    assert {"2", "4", "6.3", "6.4", "8"} <= sections(ROOT / "docs" / "design.md")
    assert {"A", "B", "C", "C.2", "C.3b", "C.4.2", "C.4.1b"} <= sections(ROOT / "docs" / "math.md")


@pytest.mark.parametrize("name, home, ok", [
    ("tmpc.compiler.rotations.quat_from_matrix", None, True),
    ("tmpc.compiler.rotations.no_such_function", None, False),
    ("tmpc.runtime.validate_kinematics", None, False),      # a module of the old flat layout
    ("quat_matrix", "tmpc.compiler.rotations", True),
    ("quat_matrix", None, False),                          # docs need qualified names
    (".validate_kinematics", "tmpc.runtime.validate.core", False),
])
def test_the_resolver_can_fail(name, home, ok):
    assert resolves(name, home) is ok
