"""The editor's workspace model: open documents over the files on disk, and what checks what.

A document is checked as ``tmpc run`` would read it: a domain or problem named by a run
configuration in the workspace is checked through that configuration (its scene and Lua file
too); otherwise a problem is paired with the domain its ``(:domain NAME)`` names anywhere in the
workspace, and a domain with the open problems that name it. Open documents' unsaved text wins
over the disk (:class:`Overlay`).
"""

from __future__ import annotations

import os
import re
import time
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

from tmpc.lang.diagnostics import Diagnostic, TmpcError
from tmpc.lang.program import WORLD_SUFFIXES, CheckReport, Workspace, check_parsed, check_paths
from tmpc.lang.reader import ParsedFile, parse_source
from tmpc.lang.source import SourceFile
from tmpc.lang.world import is_run_config, load_config

PDDL_SUFFIXES = (".pddl", ".tmpc")
#: at most this many files are indexed per workspace folder (a home directory opened by mistake
#: must not stall the server)
MAX_FILES = 4000
#: the disk listing is reused this long (saves and opens refresh it at once)
RESCAN_SECONDS = 10.0
_SKIP_DIRS = {".git", ".venv", "venv", "node_modules", "__pycache__", ".tox", "build", "dist"}
_DOMAIN_RE = re.compile(r"\(\s*define\s*\(\s*domain\s+([^\s()]+)", re.I)
_PROBLEM_DOMAIN_RE = re.compile(r"\(\s*:domain\s+([^\s()]+)", re.I)


def norm(path: str | Path) -> str:
    """The one spelling of a path the server uses (absolute, normalised)."""
    return os.path.normpath(os.path.abspath(os.path.expanduser(str(path))))


@dataclass
class Document:
    source: SourceFile
    version: int
    parsed: ParsedFile | None = None

    def parse(self) -> ParsedFile:
        if self.parsed is None:
            self.parsed = parse_source(self.source)
        return self.parsed


class Overlay(Workspace):
    """A :class:`~tmpc.lang.program.Workspace` that reads open documents from the editor."""

    def __init__(self, project: "Project"):
        super().__init__()
        self.project = project

    def load(self, path) -> ParsedFile:
        doc = self.project.documents.get(norm(path))
        if doc is None:
            return super().load(path)
        key = str(path)
        if key not in self.parsed:
            parsed = doc.parse()
            self.files[key] = parsed.source
            self.parsed[key] = parsed
        return self.parsed[key]


@dataclass
class ConfigInfo:
    path: str
    domain: str
    problem: str
    semantics: str | None


@dataclass
class Project:
    roots: list[str] = field(default_factory=list)
    documents: dict[str, Document] = field(default_factory=dict)
    #: sniffed kinds: path -> (kind, name, stamp) as :meth:`kind` finds them ("" when neither);
    #: the stamp is the open document's version or the file's mtime
    _kinds: dict[str, tuple[str, str, tuple]] = field(default_factory=dict)
    _configs: dict[str, tuple[int, ConfigInfo | None]] = field(default_factory=dict)
    _disk: tuple[float, list[str]] | None = None

    # ---- documents -------------------------------------------------------------------------
    def open(self, path: str, text: str, version: int) -> Document:
        doc = Document(SourceFile(path, text), version)
        self.documents[path] = doc
        return doc

    def close(self, path: str) -> None:
        self.documents.pop(path, None)

    def text(self, path: str) -> str | None:
        doc = self.documents.get(path)
        if doc is not None:
            return doc.source.text
        try:
            return Path(path).read_text(encoding="utf-8-sig")
        except (OSError, UnicodeDecodeError):
            return None

    # ---- the index ---------------------------------------------------------------------------
    def files(self, suffixes: tuple[str, ...]) -> list[str]:
        """Workspace files with these suffixes (open documents first, then the disk)."""
        out = [p for p in self.documents if p.lower().endswith(suffixes)]
        seen = set(out)
        return out + [p for p in self._disk_files() if p.lower().endswith(suffixes)
                      and p not in seen]

    def rescan(self) -> None:
        """Forget the disk listing (a file was saved, created or deleted)."""
        self._disk = None

    def _disk_files(self) -> list[str]:
        now = time.monotonic()
        if self._disk is not None and now - self._disk[0] < RESCAN_SECONDS:
            return self._disk[1]
        found: list[str] = []
        for root in self.roots:
            for dirpath, dirnames, filenames in os.walk(root):
                dirnames[:] = sorted(d for d in dirnames if d not in _SKIP_DIRS
                                     and not d.startswith("."))
                found += [norm(os.path.join(dirpath, f)) for f in sorted(filenames)]
                if len(found) > MAX_FILES:
                    break
        self._disk = (now, found[:MAX_FILES])
        return self._disk[1]

    def kind(self, path: str) -> tuple[str, str] | None:
        """("domain", NAME) or ("problem", DOMAIN NAME) by a quick look at the text."""
        doc = self.documents.get(path)
        stamp = ("open", doc.version) if doc is not None else ("disk", _mtime(path))
        hit = self._kinds.get(path)
        if hit is not None and hit[2] == stamp:
            return hit[:2] if hit[0] else None
        text = self.text(path) or ""
        m = _DOMAIN_RE.search(text)
        got = ("domain", m.group(1).lower()) if m else None
        if got is None:
            m = _PROBLEM_DOMAIN_RE.search(text)
            got = ("problem", m.group(1).lower()) if m else None
        self._kinds[path] = (*(got or ("", "")), stamp)
        return got

    def domains_named(self, name: str) -> list[str]:
        return [p for p in self.files(PDDL_SUFFIXES) if self.kind(p) == ("domain", name)]

    def problems_of(self, name: str) -> list[str]:
        return [p for p in self.files(PDDL_SUFFIXES) if self.kind(p) == ("problem", name)]

    def configs(self) -> list[ConfigInfo]:
        """Run configurations in the workspace (read through the lang loader, cached)."""
        out = []
        for p in self.files((".toml", ".json")):
            stamp = _mtime(p)
            hit = self._configs.get(p)
            if hit is None or hit[0] != stamp:
                info = None
                try:
                    if is_run_config(p):
                        c = load_config(p)
                        info = ConfigInfo(p, norm(c.domain), norm(c.problem),
                                          norm(c.semantics) if c.semantics else None)
                except TmpcError:
                    info = None
                self._configs[p] = hit = (stamp, info)
            if hit[1] is not None:
                out.append(hit[1])
        return out

    def config_for(self, path: str) -> ConfigInfo | None:
        """The first run configuration (by path) naming ``path`` as domain, problem or Lua file."""
        for c in sorted(self.configs(), key=lambda c: c.path):
            if path in (c.domain, c.problem, c.semantics):
                return c
        return None

    # ---- checking ----------------------------------------------------------------------------
    def related(self, path: str) -> list[str]:
        """The PDDL files checked together with ``path`` (it first)."""
        kind = self.kind(path)
        if kind is None:
            return [path]
        if kind[0] == "problem":
            doms = self.domains_named(kind[1])
            return [path, *doms[:1]]
        open_problems = [p for p in self.documents if self.kind(p) == ("problem", kind[1])]
        return [path, *open_problems]

    def check(self, path: str) -> "Check":
        """Every diagnostic ``tmpc check`` gives for ``path`` and the files read with it."""
        ws = Overlay(self)
        config = self.config_for(path)
        try:
            if path.lower().endswith(WORLD_SUFFIXES):
                report = check_paths([path], ws)
            elif config is not None:
                report = check_paths([config.path], ws)
                extra = [p for p in self.related(path) if p not in (config.domain, config.problem)]
                if extra:
                    more = check_parsed(ws, [ws.load(p) for p in extra])
                    report.diagnostics += more.diagnostics
                    report.sources += more.sources
            else:
                report = check_parsed(ws, [ws.load(p) for p in self.related(path)])
        except TmpcError as exc:      # an unreadable file, a configuration that does not load
            ws.files.update(exc.files)
            report = CheckReport(ws, list(exc.diagnostics), [])
        return Check(path, report, config)


@dataclass
class Check:
    """One check: the report and the diagnostics by (normalised) file."""

    path: str
    report: CheckReport
    config: ConfigInfo | None

    @cached_property
    def files(self) -> dict[str, SourceFile]:
        return {norm(k): v for k, v in self.report.workspace.files.items()}

    def by_file(self) -> dict[str, list[Diagnostic]]:
        """Diagnostics by file, for ``path`` and every file the check read (an empty list
        clears a file's old diagnostics: a domain edit can fix its problem's errors)."""
        out: dict[str, list[Diagnostic]] = {self.path: [], **{p: [] for p in self.files}}
        for d in self.report.diagnostics:
            where = norm(d.span.path) if d.span is not None else self.path
            out.setdefault(where, []).append(d)
        return out


def _mtime(path: str) -> int:
    try:
        return os.stat(path).st_mtime_ns
    except OSError:
        return -1


__all__ = ["Project", "Document", "Check", "ConfigInfo", "norm"]
