"""Legacy Lua predicate files, run in a sandboxed Lua 5.4 (lupa).

planet files define global functions built from the combinators of planet's prelude
(``Eq Le Lt Ge Gt And Or Not True False``); tmit-star files return a table
``{['pddl-name'] = fn}`` and take dual numbers and math from ``require('tmit-star')``. tmpc
provides both, written for tmpc (``stdlib/lua/``): ``sandbox.lua`` (limits, environment, entry
points) and ``values.lua`` (tracer, dual numbers, ``math``), both trusted, ``planet.lua`` (the
prelude) and ``tmit-star.lua`` (the module). See ``docs/lua.md``.

The sandbox: user code runs in its own environment without ``os io debug load loadstring dofile
loadfile package coroutine collectgarbage`` and ``string.dump``; ``require`` serves only
``'tmit-star'``; no Python object is reachable from Lua. Each call runs under an instruction
budget (a count hook) and the runtime under a memory cap. Every failure becomes a
:class:`~tmpc.lang.diagnostics.LuaError` whose diagnostic points at the Lua file and line.

lupa is imported lazily: importing :mod:`tmpc.lang` never loads it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Sequence

from tmpc.lang.diagnostics import Diagnostic, LuaError, Related, error
from tmpc.lang.source import SourceFile, Span

DIALECTS = ("planet", "tmit-star")
_LABEL = "tmpc-user"      # the chunk name user code runs under (messages are re-located)
_PREFIX = re.compile(r"^([^\s:]+):(\d+): ")

#: what kind of failure (as the Lua core reports it) -> diagnostic code at load / at a call
_CODES = {
    "denied": ("E703", "E703"),
    "limit": ("E704", "E704"),
    "time": ("E704", "E704"),
    "memory": ("E705", "E705"),
    "size": ("E705", "E705"),
    "badreturn": ("E710", "E706"),
    "field": ("E709", "E709"),
    "error": ("E701", "E702"),
    "untraceable": ("E701", "E702"),
}
_HINTS = {
    "E703": "tmpc runs Lua predicates in a sandbox: no os, io, debug, load*, dofile, package, "
            "coroutine or string.dump; require serves only 'tmit-star'",
    "E704": "an infinite loop? if the predicate really needs more, raise the limit: "
            "`--lua-instructions N` / `--lua-seconds S` on the command line, or `lua_instructions`"
            " / `lua_seconds` under [planner] in a run manifest",
    "E709": "read only the fields the message lists (docs/lua.md, Tracing); a surface's "
            "fields need an argument that has a support region",
    "E705": "if the file really needs more, raise the limit: `--lua-memory BYTES` on the command "
            "line, or `lua_memory` under [planner] in a run manifest (one string.rep may build "
            "at most 16 MiB)",
}


@dataclass(frozen=True)
class LuaLimits:
    """Per-call instruction budget and CPU time (seconds), per-file memory cap (bytes), and the
    largest string one ``string.rep`` may build (bytes)."""

    instructions: int = 10_000_000
    memory: int = 64 * 1024 * 1024
    seconds: float = 10.0
    string_bytes: int = 16 * 1024 * 1024


#: limits given on the command line (``--lua-instructions`` ...): they win over any
#: configuration's, so a legacy planet/tmit-star configuration, which has no place for them,
#: can raise them too. Set by the CLI (:func:`override_lua_limits`).
_OVERRIDES: dict[str, float] = {}


def override_lua_limits(instructions: int | None = None, seconds: float | None = None,
                        memory: int | None = None) -> None:
    """Make these limits (the ones given) win over every configuration's in this process."""
    given = {"lua_instructions": instructions, "lua_seconds": seconds, "lua_memory": memory}
    _OVERRIDES.update({k: v for k, v in given.items() if v is not None})


def clear_lua_overrides() -> dict[str, int | float]:
    """Forget the limits :func:`override_lua_limits` set; returns them (keyword arguments for
    :func:`override_lua_limits`, to restore them)."""
    saved = {k.removeprefix("lua_"): v for k, v in _OVERRIDES.items()}
    _OVERRIDES.clear()
    return saved


def lua_limits(config) -> LuaLimits:
    """The sandbox's limits: the command line's (:func:`override_lua_limits`), else a run
    configuration's ``[planner]`` ``lua_instructions``, ``lua_seconds`` and ``lua_memory``, else
    the defaults (also without a configuration)."""
    params = {**dict(getattr(config, "params", ()) or ()), **_OVERRIDES}
    base = LuaLimits()
    return LuaLimits(instructions=int(params.get("lua_instructions", base.instructions)),
                     memory=int(params.get("lua_memory", base.memory)),
                     seconds=float(params.get("lua_seconds", base.seconds)),
                     string_bytes=base.string_bytes)


@dataclass(frozen=True)
class LuaFunction:
    """A function a Lua file offers as a predicate: its name (planet: global; tmit-star: key
    of the returned table), its Lua parameter count and the line it is defined on."""

    name: str
    nparams: int
    vararg: bool
    line: int


@dataclass(frozen=True)
class LuaOutcome:
    """What one call into the sandbox gave: ``kind`` is ``ok`` or a failure kind
    (``untraceable error denied field limit memory badreturn``)."""

    kind: str
    message: str = ""
    line: int | None = None
    values: tuple = ()

    @property
    def ok(self) -> bool:
        return self.kind == "ok"


class _Sandbox:
    """One lupa runtime with tmpc's core loaded; only numbers, strings and Lua tables cross."""

    def __init__(self, limits: LuaLimits):
        import lupa
        try:
            from lupa import lua54 as impl
        except ImportError:          # pragma: no cover - lupa built without Lua 5.4
            impl = lupa
        self.lupa = impl

        def no_attributes(obj, name, is_setting):
            raise AttributeError("Python objects are not reachable from tmpc's Lua sandbox")

        self.rt = impl.LuaRuntime(register_eval=False, register_builtins=False,
                                  unpack_returned_tuples=True, attribute_filter=no_attributes,
                                  max_memory=limits.memory)
        files = resources.files("tmpc.stdlib").joinpath("lua")
        texts = [files.joinpath(n).read_text("utf-8")
                 for n in ("sandbox.lua", "values.lua", "planet.lua", "tmit-star.lua")]
        chunk = self.rt.globals().load(texts[0], "=tmpc/sandbox.lua", "t")
        self.api = chunk(*texts[1:])
        # The core keeps what it needs in locals; nothing else may reach these.
        self.rt.execute("python, debug, os, io, load, loadstring, dofile, loadfile, require, "
                        "package, collectgarbage = nil")
        self.api.set_budget(limits.instructions, limits.seconds)
        self.api.set_string_cap(limits.string_bytes)

    def located(self, fn: str, *args) -> tuple:
        """Call a core function; if it fails (not by a limit), call it again with line tracking
        so the error's line is exact (a tail call hides the user's frame from the stack)."""
        raw = self.call(fn, *args, False)
        if raw[0] in ("ok", "syntax", "memory", "limit", "time", "badreturn") or \
                (raw[0] == "error" and raw[1] in ("memory", "limit", "time")):
            return raw
        return self.call(fn, *args, True)

    def call(self, fn: str, *args) -> tuple:
        """Call a core function; a failure outside the core's guard (memory) becomes a tuple."""
        try:
            out = getattr(self.api, fn)(*args)
        except self.lupa.LuaMemoryError:
            try:
                self.api.reset()
            except self.lupa.LuaError:          # pragma: no cover - still out of memory
                pass
            return ("memory", "not enough memory", None)
        except self.lupa.LuaError as e:                       # pragma: no cover - a core bug
            return ("error", str(e).split("\n", 1)[0], None)
        return out if isinstance(out, tuple) else (out,)

    def table(self, values) -> object:
        return self.rt.table_from(list(values))


def _outcome(raw: tuple) -> LuaOutcome:
    kind = raw[0]
    if kind == "ok":
        return LuaOutcome("ok", values=tuple(raw[1:]))
    message = str(raw[1]) if len(raw) > 1 and raw[1] is not None else ""
    line = raw[2] if len(raw) > 2 and raw[2] is not None else None
    m = _PREFIX.match(message)
    if m:                     # "chunk:LINE: text": keep the text, use the line if ours
        if line is None and m.group(1) == _LABEL:
            line = int(m.group(2))
        message = message[m.end():]
    return LuaOutcome(kind, message, int(line) if line is not None else None)


@dataclass(eq=False)
class LuaModule:
    """A loaded Lua predicate file: its functions, ready to trace or evaluate."""

    path: str
    source: SourceFile
    dialect: str
    functions: dict[str, LuaFunction]
    limits: LuaLimits
    _sandbox: _Sandbox = field(repr=False)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(sorted(self.functions))

    @property
    def files(self) -> dict[str, SourceFile]:
        return {self.path: self.source}

    def lookup(self, pddl_name: str) -> str | None:
        """The function implementing a PDDL predicate: same name, else ignoring case, else with
        ``-`` and ``_`` taken as equal (planet's globals cannot contain ``-``)."""
        if pddl_name in self.functions:
            return pddl_name
        key = pddl_name.lower()
        for fold in (lambda s: s.lower(), lambda s: s.lower().replace("-", "_")):
            hits = [n for n in self.names if fold(n) == fold(key)]
            if len(hits) == 1:
                return hits[0]
        return None

    # ---- calls ---------------------------------------------------------------------------
    def trace(self, name: str, nargs: int) -> LuaOutcome:
        """Call ``name`` on proxy arguments. ``values`` = (serialized IR, result id, kinds)."""
        return _outcome(self._sandbox.located("trace", name, nargs, self.dialect))

    def evaluate(self, name: str, poses: Sequence[float], boxes: Sequence, names: Sequence,
                 gradient: bool) -> LuaOutcome:
        """Call ``name`` at concrete values with dual numbers. ``poses`` is flat (7 per argument:
        px py pz rx ry rz rw); ``boxes`` per argument: 6 numbers (lower, upper in the object's
        frame) or None; ``names`` per argument: str or None. ``values`` = (distance, gradient
        Lua table, kinds)."""
        nargs = len(boxes)
        sb = self._sandbox
        lua_boxes = sb.table([sb.table(b) if b is not None else False for b in boxes])
        lua_names = sb.table([n if n is not None else False for n in names])
        return _outcome(sb.located("evaluate", name, nargs, self.dialect, sb.table(poses),
                                   lua_boxes, lua_names, gradient))

    # ---- diagnostics ----------------------------------------------------------------------
    def line_span(self, line: int | None) -> Span | None:
        """The span of a 1-based line's text (without its indentation)."""
        if line is None or not 1 <= line <= self.source.line_count:
            return None
        text = self.source.line_text(line)
        start = self.source.offset(line, 1) + (len(text) - len(text.lstrip()))
        return self.source.span(start, max(start + 1, self.source.offset(line, 1) + len(text)))

    def diagnostic(self, outcome: LuaOutcome, at_call: bool, function: str | None = None,
                   fallback_line: int | None = None) -> Diagnostic:
        """The error diagnostic of a failed load or call."""
        code = _CODES.get(outcome.kind, ("E701", "E702"))[1 if at_call else 0]
        where = f" in `{function}`" if function else ""
        what = {"limit": f"instruction limit ({self.limits.instructions:,}) exceeded",
                "time": f"time limit ({self.limits.seconds:g} s of CPU per call) exceeded",
                "memory": f"memory limit ({self.limits.memory:,} bytes) exceeded",
                "badreturn": "wrong result type: " + outcome.message}.get(
                    outcome.kind, outcome.message)
        line = outcome.line if outcome.line is not None else fallback_line
        span = self.line_span(line)
        msg = f"Lua{where}: {what}"
        if span is None:
            msg += f" ({self.path})"
        return error(code, msg, span, _HINTS.get(code))


def _read(path: str | Path) -> SourceFile:
    try:
        return SourceFile.read(path)
    except UnicodeDecodeError:
        raise LuaError(error("E011", f"`{path}` is not UTF-8 text", None)) from None
    except OSError as e:
        raise LuaError(error("E010", f"cannot read `{path}`: {e.strerror or e}", None)) from None


def load_lua_predicates(path: str | Path, dialect: str | None = None, *, text: str | None = None,
                        limits: LuaLimits | None = None) -> LuaModule:
    """Run a Lua predicate file in a fresh sandbox and list its functions.

    ``dialect``: ``"planet"``, ``"tmit-star"`` or None to tell from the file (a chunk returning a
    table is tmit-star style, one returning nothing planet style). ``text`` overrides the file's
    contents (then ``path`` only names it). Raises :class:`LuaError`.
    """
    if dialect not in (None, *DIALECTS):
        raise ValueError(f"unknown Lua dialect {dialect!r} (expected one of {DIALECTS})")
    source = SourceFile(str(path), text) if text is not None else _read(path)
    limits = limits or LuaLimits()
    sandbox = _Sandbox(limits)
    module = LuaModule(str(path), source, dialect or "planet", {}, limits, sandbox)
    raw = sandbox.located("load", source.text, _LABEL, dialect or "auto")
    if raw[0] == "syntax":
        out = _outcome(("error", raw[1], None))
        raise LuaError(error("E700", f"Lua syntax error: {out.message}",
                             module.line_span(out.line)), module.files)
    if raw[0] == "error":
        out = _outcome(tuple(raw[1:4]))
        raise LuaError(module.diagnostic(out, at_call=False), module.files)
    if raw[0] == "badreturn":
        raise LuaError(error("E710", f"the Lua file returns {raw[1]}; a planet file returns "
                             "nothing, a tmit-star file a table of functions",
                             _last_return(module)), module.files)
    style, infos = raw[1], raw[2]
    if dialect is not None and style != dialect:
        found = "returns a table (tmit-star style)" if style == "tmit-star" else \
            "returns nothing (planet style)"
        raise LuaError(error("E710", f"expected a {dialect} Lua file, but this one {found}",
                             _last_return(module)), module.files)
    module.dialect = style
    module.functions = {
        str(k): LuaFunction(str(k), int(v["nparams"]), bool(v["vararg"]), int(v["line"]))
        for k, v in infos.items()}
    return module


def _last_return(module: LuaModule) -> Span | None:
    """The last top-level-looking `return` line (where a chunk's result is written)."""
    for line in range(module.source.line_count, 0, -1):
        if module.source.line_text(line).startswith("return"):
            return module.line_span(line)
    return None


def arity_diagnostic(module: LuaModule, fn: LuaFunction, pddl_name: str, nargs: int,
                     decl_span: Span | None) -> Diagnostic:
    related = [Related(decl_span, f"`{pddl_name}` declared here")] if decl_span else []
    return error("E708", f"Lua function `{fn.name}` takes {fn.nparams} parameter(s) but "
                 f"predicate `{pddl_name}` has {nargs}", module.line_span(fn.line), None, related)
