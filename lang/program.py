"""Loading: files -> parsed definitions -> paired domain/problem -> :class:`CheckedProgram`.

Stages are distinct types: :class:`ParsedFile` (syntax only) -> :class:`Program` (a domain, an
optional problem and the modules they include) -> :class:`CheckedProgram` (no errors).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from tmpc.lang import ast as A
from tmpc.lang.checker import CheckedProgram, Checker
from tmpc.lang.diagnostics import (
    CheckError,
    Diagnostic,
    InputError,
    Related,
    TmpcError,
    error,
    not_utf8,
    warning,
)
from tmpc.lang.lua import arity_diagnostic, load_lua_predicates, lua_limits
from tmpc.lang.reader import ParsedFile, parse_source
from tmpc.lang.semantics_module import apply_semantics
from tmpc.lang.source import SourceFile, Span
from tmpc.lang.world import (
    LoadReport,
    is_run_config,
    load_allowed_pairs,
    load_config,
    load_config_scene,
    load_scene,
    load_urdf,
    mesh_search_dirs,
)

STDLIB_PREFIX = "tmpc/"
MODULE_SUFFIX = ".tmpc"


@dataclass
class Workspace:
    """Every source file read in one run (for rendering diagnostics) and their parses."""

    files: dict[str, SourceFile] = field(default_factory=dict)
    parsed: dict[str, ParsedFile] = field(default_factory=dict)
    #: run configurations read (their domain, problem and Lua file are checked too)
    configs: list = field(default_factory=list)

    def load(self, path: str | Path) -> ParsedFile:
        key = str(path)
        if key in self.parsed:
            return self.parsed[key]
        try:
            src = SourceFile.read(path)
        except FileNotFoundError:
            raise InputError(error("E010", f"no such file: {key}", None)) from None
        except IsADirectoryError:
            raise InputError(error("E010", f"{key} is a directory, not a file", None)) from None
        except UnicodeDecodeError as exc:
            raise InputError(*not_utf8(key, exc, "save the file as UTF-8")) from None
        except OSError as exc:
            raise InputError(error("E010", f"cannot read {key}: {exc.strerror}", None)) from None
        return self.add_source(src)

    def add_source(self, src: SourceFile) -> ParsedFile:
        self.files[src.path] = src
        parsed = parse_source(src)
        self.parsed[src.path] = parsed
        return parsed

    def load_stdlib(self, name: str, span: Span | None) -> ParsedFile | None:
        key = f"<stdlib>/{name}{MODULE_SUFFIX}"
        if key in self.parsed:
            return self.parsed[key]
        try:
            text = resources.files("tmpc.stdlib").joinpath(name + MODULE_SUFFIX).read_text("utf-8")
        except (FileNotFoundError, OSError):
            return None
        return self.add_source(SourceFile(key, text))


@dataclass(frozen=True)
class Program:
    """A domain with an optional problem and the modules it includes (parsed, unchecked)."""

    domain: A.Domain
    problem: A.Problem | None = None
    modules: tuple[A.Domain, ...] = ()

    def check(self) -> tuple[CheckedProgram | None, list[Diagnostic]]:
        checker = Checker(self.domain, self.problem, self.modules)
        diags = checker.run()
        if any(d.is_error for d in diags):
            return None, diags
        return CheckedProgram(self.domain, self.problem, checker.scope, self.modules,
                              tuple(diags)), diags


@dataclass
class CheckReport:
    """Result of checking a set of files."""

    workspace: Workspace
    diagnostics: list[Diagnostic]
    programs: list[CheckedProgram]
    #: every program found, checked or not, with its modules (what an editor navigates)
    sources: list[Program] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not any(d.is_error for d in self.diagnostics)


def resolve_includes(ws: Workspace, domain: A.Domain, diags: list[Diagnostic],
                     chain: tuple[str, ...] = ()) -> tuple[A.Domain, ...]:
    """Load the modules ``domain`` includes (transitively), depth first, each once."""
    out: list[A.Domain] = []
    for inc in domain.includes:
        if inc.module in chain:
            diags.append(error("E124", f"module `{inc.module}` includes itself", inc.span))
            continue
        parsed = _load_module(ws, inc, diags)
        if parsed is None:
            continue
        diags.extend(parsed.diagnostics)
        for d in parsed.definitions:
            if isinstance(d, A.Domain):
                out.extend(resolve_includes(ws, d, diags, chain + (inc.module,)))
                out.append(d)
    seen, unique = set(), []
    for m in out:
        if id(m) not in seen:
            seen.add(id(m))
            unique.append(m)
    return tuple(unique)


def _load_module(ws: Workspace, inc: A.Include, diags: list[Diagnostic]) -> ParsedFile | None:
    if inc.module.startswith(STDLIB_PREFIX):
        name = inc.module[len(STDLIB_PREFIX):]
        parsed = ws.load_stdlib(name, inc.span)
        if parsed is None:
            diags.append(error("E123", f"no stdlib module `{inc.module}`", inc.span,
                               "available: " + ", ".join(stdlib_modules())))
        return parsed
    base = Path(inc.span.path).parent
    for cand in (base / inc.module, base / (inc.module + MODULE_SUFFIX)):
        if cand.is_file():
            return ws.load(cand)
    diags.append(error("E123", f"cannot find module `{inc.module}`", inc.span,
                       f"looked for {inc.module} and {inc.module}{MODULE_SUFFIX} next to this "
                       "file; stdlib modules start with `tmpc/`"))
    return None


def stdlib_modules() -> list[str]:
    root = resources.files("tmpc.stdlib")
    return sorted(STDLIB_PREFIX + p.name[:-len(MODULE_SUFFIX)] for p in root.iterdir()
                  if p.name.endswith(MODULE_SUFFIX))


def _find_domain_for(problem: A.Problem, ws: Workspace) -> A.Domain | None:
    """A problem given alone: look for its domain in a sibling file (IPC/legacy layout)."""
    folder = Path(problem.span.path).parent
    want = problem.domain_name.key if problem.domain_name else None
    cands = sorted(folder.glob("*.pddl"))
    mine = Path(problem.span.path).name
    # Prefer files named like a domain, then the one sharing the longest prefix with the problem
    # (IPC ships `p02-domain.pddl` next to `p02-airport1-p1.pddl`).
    cands.sort(key=lambda p: ("domain" not in p.name.lower(),
                              -len(os.path.commonprefix([mine, p.name])), p.name))
    for cand in cands[:50]:
        if str(cand) == problem.span.path:
            continue
        try:
            parsed = ws.load(cand)
        except InputError:
            continue
        for d in parsed.definitions:
            if isinstance(d, A.Domain) and d.form == "domain" and (want is None or d.name.key == want):
                return d
    return None


def build_programs(ws: Workspace, parsed: list[ParsedFile],
                   diags: list[Diagnostic]) -> list[Program]:
    """Pair every problem with its domain; lone domains become programs of their own."""
    # a semantics module is applied to the domain of a run configuration that names it
    # (:func:`_with_semantics`); alone it is read for its syntax only
    domains = [d for p in parsed for d in p.definitions
               if isinstance(d, A.Domain) and d.form != "semantics"]
    problems = [d for p in parsed for d in p.definitions if isinstance(d, A.Problem)]
    by_name: dict[str, A.Domain] = {}
    for d in domains:
        by_name.setdefault(d.name.key, d)   # several domains of one name: the first given wins
    used: set[int] = set()
    programs: list[Program] = []
    for pb in problems:
        dom = by_name.get(pb.domain_name.key) if pb.domain_name else None
        if dom is None and len(domains) == 1:
            dom = domains[0]
        if dom is None:
            dom = _find_domain_for(pb, ws)
            if dom is not None:
                diags.append(warning("W011", f"checked with the domain in {dom.span.path}",
                                     pb.domain_name.span if pb.domain_name else pb.span,
                                     "pass the domain file too to choose it yourself"))
        if dom is None:
            diags.append(error("E210", f"no domain found for problem `{pb.name.text}`",
                               pb.domain_name.span if pb.domain_name else pb.name.span,
                               "pass the domain file as well: `tmpc check domain.pddl "
                               "problem.pddl`"))
            continue
        used.add(id(dom))
        programs.append(Program(dom, pb))
    for dom in domains:
        if id(dom) not in used:
            programs.append(Program(dom, None))
    return programs


#: Non-PDDL inputs `tmpc check` also reads, by suffix; their loaders are imported on demand
#: (lupa for Lua, yourdfpy for URDF), so checking PDDL alone stays light.
WORLD_SUFFIXES = (".lua", ".toml", ".json", ".xml", ".urdf", ".csv")


def _check_world_file(path: Path, ws: Workspace) -> list[Diagnostic]:
    """Load a Lua file, run configuration, scene or URDF the way a run would; its problems
    become diagnostics."""
    suffix = path.suffix.lower()
    try:
        if suffix == ".lua":
            load_lua_predicates(path)
        elif suffix == ".urdf":
            load_urdf(path.resolve())
        elif suffix == ".csv":                   # an allowed-collision (blocklist) CSV
            report = LoadReport()
            load_allowed_pairs(path, report)
            ws.files.update(report.files)
            return list(report.warnings)
        elif is_run_config(path):
            report = LoadReport()
            config = load_config(path, report=report)
            # the scene, Lua file, domain and problem it names are checked as a run reads them
            # every mesh must be found and readable (E514, E565): a run needs them all
            load_config_scene(config, report=report, mesh_fallback_dirs=mesh_search_dirs(),
                              check_meshes=True)
            ws.files.update(report.files)
            ws.configs.append(config)
            return list(report.warnings)
        else:
            report = LoadReport()
            load_scene(path, report=report, mesh_fallback_dirs=mesh_search_dirs(),
                       check_meshes=True)
            ws.files.update(report.files)
            return list(report.warnings)
    except TmpcError as exc:
        ws.files.update(exc.files)
        return list(exc.diagnostics)
    return []


def check_paths(paths: list[str | Path], ws: Workspace | None = None,
                semantics: dict[str, Path] | None = None) -> CheckReport:
    """Parse and check files. Raises :class:`InputError` only for unreadable PDDL files.
    ``semantics``: problem file -> the semantics module that gives its domain meaning (run
    configurations read here add theirs)."""
    ws = ws or Workspace()
    semantics = dict(semantics or {})
    world_diags: list[Diagnostic] = []
    pddl = []
    for p in paths:
        if Path(p).suffix.lower() in WORLD_SUFFIXES:
            if not Path(p).is_file():
                raise InputError(error("E010", f"no such file: {p}", None))
            before = len(ws.configs)
            world_diags += _check_world_file(Path(p), ws)
            for config in ws.configs[before:]:
                pddl += [config.domain, config.problem]
                if config.module is not None:
                    semantics[str(Path(config.problem).resolve())] = config.module
        else:
            pddl.append(p)
    report = check_parsed(ws, [ws.load(p) for p in dict.fromkeys(pddl)], semantics)
    report.diagnostics[:0] = world_diags
    if ws.configs and report.ok:
        report.diagnostics += _check_semantics(ws, report.programs)
    return report


def config_program(config, programs) -> CheckedProgram | None:
    """The checked program whose problem is the run configuration ``config``'s (None: none)."""
    want = Path(config.problem).resolve()
    return next((p for p in programs if p.problem is not None and p.problem.span is not None
                 and Path(p.problem.span.path).resolve() == want), None)


def _check_semantics(ws: Workspace, programs) -> list[Diagnostic]:
    """Every geometric predicate without inline semantics needs a function in the Lua file the
    run configuration names (E707), as the compiler will look it up."""
    out: list[Diagnostic] = []
    for config in ws.configs:
        prog = config_program(config, programs)
        if prog is None:
            continue
        external = [d for d in prog.domain.predicates if d.external]
        if not external:
            continue
        if config.semantics is None:
            for d in external:
                out.append(error("E707", f"geometric predicate `{d.name.text}` has no inline "
                                 f"semantics and {config.path} names no Lua file", d.span,
                                 "add `semantics = \"predicates.lua\"` to the configuration"))
            continue
        try:
            module = load_lua_predicates(config.semantics, limits=lua_limits(config))
        except TmpcError as exc:
            ws.files.update(exc.files)
            out.extend(exc.diagnostics)
            continue
        ws.files.update(module.files)
        for d in external:
            fname = module.lookup(d.name.text)
            if fname is None:
                related = [Related(module.line_span(1), "the Lua file")] \
                    if module.line_span(1) else []
                out.append(error("E707", f"no Lua function for geometric predicate "
                                 f"`{d.name.text}` in {module.path}", d.span,
                                 "the file defines: " + (", ".join(module.names) or "none"),
                                 related))
                continue
            fn = module.functions[fname]
            if not fn.vararg and fn.nparams != len(d.params):      # as the compiler checks
                out.append(arity_diagnostic(module, fn, d.name.text, len(d.params), d.span))
    return out


def check_parsed(ws: Workspace, parsed: list[ParsedFile],
                 semantics: dict[str, Path] | None = None) -> CheckReport:
    diags: list[Diagnostic] = [d for p in parsed for d in p.diagnostics]
    checked: list[CheckedProgram] = []
    sources: list[Program] = []
    # Programs are checked even when a file has syntax errors, so an editor sees name and type
    # errors next to them (the reader returns a partial tree).
    for prog in build_programs(ws, parsed, diags):
        sem_path = (semantics or {}).get(str(Path(prog.problem.span.path).resolve())) \
            if prog.problem is not None and prog.problem.span is not None else None
        if sem_path is not None:
            prog = _with_semantics(ws, prog, Path(sem_path), diags)
            if prog is None:
                continue
        else:
            prog = Program(prog.domain, prog.problem, resolve_includes(ws, prog.domain, diags))
        sources.append(prog)
        result, pdiags = prog.check()
        diags.extend(pdiags)
        if result is not None:
            checked.append(result)
    return CheckReport(ws, _dedupe(diags), checked, sources)


def _with_semantics(ws: Workspace, prog: Program, path: Path,
                    diags: list[Diagnostic]) -> Program | None:
    """``prog`` with the semantics module at ``path`` applied (docs/language.md, "Semantics
    modules"); None when the file holds no semantics module."""
    parsed = ws.load(path)
    diags.extend(parsed.diagnostics)
    sem = next((d for d in parsed.definitions if isinstance(d, A.Domain)
                and d.form == "semantics"), None)
    if sem is None:
        diags.append(error("E125", f"{path} holds no `(define (semantics NAME) ...)`",
                           Span(str(path), 0, 0) if str(path) in ws.files else None,
                           "a semantics module starts `(define (semantics NAME) (:domain D) "
                           "...)`; Lua predicate files end in .lua"))
        return None
    domain, problem, module, more = apply_semantics(prog.domain, prog.problem, sem)
    diags.extend(more)
    modules = resolve_includes(ws, module, diags) + (module,) + \
        resolve_includes(ws, prog.domain, diags)
    return Program(domain, problem, modules)


def load_checked(paths: list[str | Path]) -> CheckedProgram:
    """The one program in ``paths`` (domain + problem), or :class:`CheckError`."""
    report = check_paths(paths)
    if not report.ok:
        raise CheckError([d for d in report.diagnostics if d.is_error])
    if len(report.programs) != 1:
        raise InputError(error("E211", f"expected one domain and problem, found "
                               f"{len(report.programs)} programs", None))
    return report.programs[0]


def _dedupe(diags: list[Diagnostic]) -> list[Diagnostic]:
    seen, out = set(), []
    for d in diags:
        if d not in seen:
            seen.add(d)
            out.append(d)
    return out


__all__ = ["Workspace", "Program", "CheckReport", "check_paths", "check_parsed", "load_checked",
           "stdlib_modules", "Related"]
