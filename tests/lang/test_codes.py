"""One vocabulary of diagnostics: ``tmpc.lang.codes``, ``docs/diagnostics.md`` and the codes the
sources use agree, and a diagnostic cannot be made with a code outside the vocabulary.

Policy for (c): every code in the table is used by the sources; there is no list of retired
codes. A code that falls out of use is removed from the table and the docs (and its number is
not given to another fault).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from tests.support import ROOT
from tmpc.lang import codes
from tmpc.lang.codes import CODES, Code, lookup
from tmpc.lang.diagnostics import Diagnostic, DiagnosticCodeError, Severity, error, warning

DOC = ROOT / "docs" / "diagnostics.md"
SOURCE_FOLDERS = ("lang", "compiler", "runtime")
CODE_RE = re.compile(r"^[EWIH]\d{3}$")
ROW_RE = re.compile(r"^\| ([EWIH]\d{3}) \| (.*) \|$", re.M)
#: functions that make a diagnostic of one severity from a code given as their first argument
#: (``error``/``warning`` and the thin wrappers over them in the readers, loaders and grounder)
MAKERS = {"error": "error", "err": "error", "fail": "error", "_fail": "error",
          "record": "error", "grounding_error": "error", "warning": "warning", "warn": "warning"}


# ---- reading the docs and the sources ------------------------------------------------------
def doc_rows(text: str) -> dict[str, tuple[str, str]]:
    """code -> (severity, meaning) of each table row; a code given twice is an error."""
    out: dict[str, tuple[str, str]] = {}
    for code, meaning in ROW_RE.findall(text):
        assert code not in out, f"{code} is documented twice"
        severity = {"E": "error", "W": "warning"}.get(code[0], "?")
        if meaning.startswith("(note) "):
            severity, meaning = "note", meaning[len("(note) "):]
        out[code] = (severity, meaning)
    return out


def source_files() -> list[Path]:
    files = [p for folder in SOURCE_FOLDERS for p in sorted((ROOT / folder).rglob("*.py"))]
    # the table itself names every code: it must not count as a use
    return [p for p in files if p != ROOT / "lang" / "codes.py"]


def _maker(call: ast.Call) -> str | None:
    f = call.func
    return f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else None


def scan(text: str, where: str = "<src>"):
    """(uses, built, made) of one source: ``uses`` code -> locations of every string constant
    that is a code (f-string parts included); ``built`` locations of f-strings that assemble a
    code from pieces (``f"E{n}"``), which no table can check; ``made`` (code, severity, location)
    of each call that makes a diagnostic of a known severity from a literal code."""
    tree = ast.parse(text)
    uses: dict[str, list[str]] = {}
    built: list[str] = []
    made: list[tuple[str, str, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            if CODE_RE.match(node.value):
                uses.setdefault(node.value, []).append(f"{where}:{node.lineno}")
        elif isinstance(node, ast.JoinedStr):
            parts = node.values
            if (len(parts) > 1 and isinstance(parts[0], ast.Constant)
                    and re.fullmatch(r"[EWIH]\d{0,2}", str(parts[0].value))
                    and isinstance(parts[1], ast.FormattedValue)):
                built.append(f"{where}:{node.lineno}")
        elif isinstance(node, ast.Call) and node.args:
            first = node.args[0]
            if not (isinstance(first, ast.Constant) and isinstance(first.value, str)
                    and CODE_RE.match(first.value)):
                continue
            name = _maker(node)
            severity = MAKERS.get(name or "")
            if name == "Diagnostic" and len(node.args) > 1:
                sev = node.args[1]
                if isinstance(sev, ast.Attribute) and sev.attr in Severity.__members__:
                    severity = Severity[sev.attr].value
            if severity is not None:
                made.append((first.value, severity, f"{where}:{node.lineno}"))
    return uses, built, made


def scan_sources():
    uses: dict[str, list[str]] = {}
    built: list[str] = []
    made: list[tuple[str, str, str]] = []
    for path in source_files():
        u, b, m = scan(path.read_text(encoding="utf-8"), str(path.relative_to(ROOT)))
        for code, where in u.items():
            uses.setdefault(code, []).extend(where)
        built += b
        made += m
    return uses, built, made


@pytest.fixture(scope="module")
def sources():
    return scan_sources()


@pytest.fixture(scope="module")
def documented():
    return doc_rows(DOC.read_text(encoding="utf-8"))


# ---- (a) the table and the docs --------------------------------------------------------------
def test_every_documented_code_is_in_the_table(documented):
    missing = sorted(set(documented) - set(CODES))
    assert missing == [], f"documented in docs/diagnostics.md, not in tmpc.lang.codes: {missing}"


def test_every_code_in_the_table_is_documented(documented):
    missing = sorted(set(CODES) - set(documented))
    assert missing == [], f"in tmpc.lang.codes, not documented in docs/diagnostics.md: {missing}"


def test_table_and_docs_agree_on_severity_and_meaning(documented):
    wrong_sev = {c: (CODES[c].severity, documented[c][0]) for c in CODES.keys() & documented.keys()
                 if CODES[c].severity != documented[c][0]}
    assert wrong_sev == {}, "severity differs (table, docs)"
    wrong = sorted(c for c in CODES.keys() & documented.keys()
                   if CODES[c].meaning != documented[c][1])
    assert wrong == [], f"meaning in tmpc.lang.codes differs from docs/diagnostics.md: {wrong}"


def test_table_is_well_formed():
    assert len(CODES) > 100
    for key, entry in CODES.items():
        assert isinstance(entry, Code) and entry.code == key and CODE_RE.match(key)
        assert entry.severity in codes.SEVERITIES
        assert entry.severity == "error" if key[0] == "E" else entry.severity != "error", key
        assert entry.meaning and "\n" not in entry.meaning and entry.meaning == entry.meaning.strip()
        assert {s.value for s in Severity} >= {entry.severity}


# ---- (b) the sources use only codes of the table ----------------------------------------------
def test_every_code_the_sources_use_is_in_the_table(sources):
    uses, _, _ = sources
    unknown = {c: w for c, w in uses.items() if c not in CODES}
    assert unknown == {}, "codes used in the sources but missing from tmpc.lang.codes"


def test_no_code_is_assembled_at_run_time(sources):
    _, built, _ = sources
    assert built == [], "write a diagnostic code as one literal string, not an f-string"


def test_each_literal_code_is_made_with_its_severity(sources):
    _, _, made = sources
    assert len(made) > 100                     # the scan does see the calls
    wrong = [(c, s, w) for c, s, w in made if c in CODES and CODES[c].severity != s]
    assert wrong == [], "a code made with another severity than its table entry"


# ---- (c) every code of the table is in use -----------------------------------------------------
def test_every_code_in_the_table_is_used(sources):
    uses, _, _ = sources
    unused = sorted(set(CODES) - set(uses))
    assert unused == [], (f"codes in tmpc.lang.codes that no source uses: {unused} (remove them "
                          "from the table and docs/diagnostics.md; there is no retired list)")


# ---- the checks can fail ------------------------------------------------------------------
def test_scan_sees_codes_fstrings_and_severities():
    uses, built, made = scan('''
error("E582", "x", None)
warning("E123", f"{x}", None)
x = ("W999", "E001") if y else "H12"
self.fail("E505", span, f"bad {n}")
Diagnostic("W613", Severity.NOTE, "m", None)
f"E{n}"
f"W0{n} is here"
f"see E582 in {doc}"
''')
    assert set(uses) == {"E582", "E123", "W999", "E001", "E505", "W613"}
    assert len(built) == 2
    assert sorted(made) == [("E123", "warning", "<src>:3"), ("E505", "error", "<src>:5"),
                            ("E582", "error", "<src>:2"), ("W613", "note", "<src>:6")]


def test_doc_rows_reads_severity_and_rejects_repeats():
    text = "| code | meaning |\n|---|---|\n| E001 | a |\n| W613 | (note) b |\n| W001 | c |\n"
    assert doc_rows(text) == {"E001": ("error", "a"), "W613": ("note", "b"),
                              "W001": ("warning", "c")}
    with pytest.raises(AssertionError):
        doc_rows(text + "| E001 | again |\n")


def test_unknown_code_or_wrong_severity_is_refused():
    assert lookup("E582") is CODES["E582"]
    with pytest.raises(KeyError, match="E5820"):
        lookup("E5820")
    with pytest.raises(DiagnosticCodeError, match="E999"):
        error("E999", "a typo", None)
    with pytest.raises(DiagnosticCodeError, match="E582"):
        warning("E582", "an error code made as a warning", None)
    with pytest.raises(DiagnosticCodeError, match="W001"):
        error("W001", "a warning code made as an error", None)
    with pytest.raises(DiagnosticCodeError, match="W613"):
        Diagnostic("W613", Severity.WARNING, "W613 is a note", None)
    assert Diagnostic("W613", Severity.NOTE, "ok", None).severity is Severity.NOTE
    assert error("E582", "ok", None).is_error and not warning("W614", "ok", None).is_error


def test_codes_module_imports_only_the_standard_library():
    tree = ast.parse((ROOT / "lang" / "codes.py").read_text(encoding="utf-8"))
    assert ast.get_docstring(tree)
    imported = {a.name.split(".")[0] for n in ast.walk(tree) if isinstance(n, ast.Import)
                for a in n.names}
    imported |= {n.module.split(".")[0] for n in ast.walk(tree)
                 if isinstance(n, ast.ImportFrom) and n.module}
    assert imported <= {"__future__", "dataclasses", "typing"}, imported
