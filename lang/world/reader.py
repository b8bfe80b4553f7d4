"""Error collection shared by the scene loaders and the run configurations: load reports, the
:class:`Reader` that records every problem of a file before raising, and the typed JSON reader."""

from __future__ import annotations

import difflib
import math
import os
import re
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Iterator, NoReturn

from tmpc.lang.diagnostics import Diagnostic, Related, SceneError, error, not_utf8, warning
from tmpc.lang.jsonpos import JsonDoc, parse_json, pointer
from tmpc.lang.source import SourceFile, Span
from tmpc.lang.world.rotations import unit_quat
from tmpc.lang.world.scene import Origin, Pose, Quat, Scene

#: |norm - 1| allowed for a quaternion (it is normalised) and for R Rᵀ - I of a rotation matrix
ROTATION_TOLERANCE = 1e-3


@dataclass
class LoadReport:
    """What a load leaves besides its result: warnings and the files their spans point into."""

    warnings: list[Diagnostic] = field(default_factory=list)
    files: dict[str, SourceFile] = field(default_factory=dict)


@dataclass(frozen=True)
class SceneOptions:
    """How to find meshes. ``mesh_dir``: planet's ``objdir`` (XML ``<geom>`` paths are relative
    to it). ``mesh_fallback_dirs``: more places to look for a mesh, by its relative path and by
    its file name. ``strict_meshes=False`` turns a missing mesh into a warning (W501).
    ``check_meshes``: also read each mesh file found, and fail (E565) when it cannot be read or,
    for STL, OBJ and PLY, holds no triangles (what ``tmpc check`` does; a run finds out when it
    builds its collision world)."""

    mesh_dir: Path | None = None
    strict_meshes: bool = True
    mesh_fallback_dirs: tuple[Path, ...] = ()
    check_meshes: bool = False


class Stop(Exception):
    """An error was recorded; abandon the current part (object, section) and go on."""


def display_name(path: str) -> str:
    """The file name shown in messages (the span carries the full path)."""
    return os.path.basename(path.rstrip("/\\")) or path


def did_you_mean(word: str, choices: Iterable[str]) -> str | None:
    close = difflib.get_close_matches(word, sorted(set(choices)), n=1, cutoff=0.6)
    return f"did you mean `{close[0]}`?" if close else None


def join_hints(*hints: str | None) -> str | None:
    parts = [h for h in hints if h]
    return "; ".join(parts) if parts else None


class Reader:
    """Error collection for one file. ``fail`` records an error and raises :class:`Stop`;
    ``part()`` catches it so independent parts (objects) are all checked; ``finish`` raises one
    SceneError with everything recorded."""

    def __init__(self, source: SourceFile, report: LoadReport, legacy: bool):
        self.source, self.report, self.legacy = source, report, legacy
        self.name = display_name(source.path)
        self.errors: list[Diagnostic] = []
        report.files[source.path] = source

    def fail(self, code: str, span: Span | None, message: str, hint: str | None = None,
             related: Iterable[Related] = ()) -> NoReturn:
        self.errors.append(error(code, f"{self.name}: {message}", span, hint, related))
        raise Stop

    def record(self, code: str, span: Span | None, message: str, hint: str | None = None,
               related: Iterable[Related] = ()) -> None:
        try:
            self.fail(code, span, message, hint, related)
        except Stop:
            pass

    def warn(self, code: str, span: Span | None, message: str, hint: str | None = None) -> None:
        self.report.warnings.append(warning(code, f"{self.name}: {message}", span, hint))

    @contextmanager
    def part(self) -> Iterator[None]:
        try:
            yield
        except Stop:
            pass

    def finish(self) -> None:
        if self.errors:
            raise SceneError(self.errors, self.report.files)

    def origin(self, span: Span | None, where: str) -> Origin:
        if span is None:
            return Origin(self.source.path, pointer=where)
        line, col = self.source.line_col(span.start)
        return Origin(self.source.path, line, col, where)

    @property
    def directory(self) -> Path:
        return Path(os.path.abspath(self.source.path)).parent


def read_source(path: str | Path, what: str) -> SourceFile:
    """Read a UTF-8 input file; a missing/unreadable file is SceneError E010/E011."""
    key = str(path)
    try:
        return SourceFile.read(path)
    except FileNotFoundError:
        raise SceneError(error("E010", f"no such {what} file: {key}", None)) from None
    except IsADirectoryError:
        raise SceneError(error("E010", f"{key} is a directory, not a {what} file", None)) from None
    except UnicodeDecodeError as exc:
        raise SceneError(*not_utf8(key, exc, f"save the {what} file as UTF-8")) from None
    except OSError as exc:
        raise SceneError(error("E010", f"cannot read {what} file {key}: {exc.strerror}",
                               None)) from None


def kind(value: Any) -> str:
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if value is None:
        return "`null`"
    if isinstance(value, (int, float)):
        return f"the number {value:g}" if isinstance(value, float) else f"the number {value}"
    if isinstance(value, str):
        return f"the string \"{value}\"" if len(value) < 40 else "a string"
    return {dict: "an object", list: "an array"}[type(value)]


def fmt_num(x: float) -> str:
    return f"{x:.6g}"


class JsonReader(Reader):
    """Checked, typed access to a :class:`JsonDoc`; every error points at the offending value."""

    def __init__(self, doc: JsonDoc, report: LoadReport, legacy: bool):
        super().__init__(doc.source, report, legacy)
        self.doc = doc

    def span(self, ptr: str) -> Span:
        return self.doc.span(ptr)

    def head(self, ptr: str) -> Span:
        """The first character of the value at ``ptr`` (for "missing key" errors)."""
        s = self.doc.span(ptr)
        return Span(s.path, s.start, s.start + 1)

    @staticmethod
    def where(ptr: str) -> str:
        return ptr or "the top level"

    def type_error(self, ptr: str, value: Any, expected: str, hint: str | None = None) -> NoReturn:
        self.fail("E506", self.span(ptr), f"{self.where(ptr)}: expected {expected}, found "
                  f"{kind(value)}", hint)

    def obj(self, ptr: str, value: Any, required: Iterable[str] = (), optional: Iterable[str] = (),
            ignored: Iterable[str] = (), what: str = "an object") -> dict:
        """Check that ``value`` is an object with the required keys and no unknown ones (legacy:
        unknown keys are a warning)."""
        if not isinstance(value, dict):
            self.type_error(ptr, value, what)
        required, optional = tuple(required), tuple(optional)
        known = required + optional
        for key in value:
            if key in known or key in ignored:
                continue
            kptr = ptr + pointer(key)
            listing = "known keys: " + ", ".join(known)
            hint = join_hints(did_you_mean(key, known), listing)
            if self.legacy:
                self.warn("W500", self.doc.key_span(kptr),
                          f"{self.where(ptr)}: unknown key \"{key}\" (ignored)", hint)
            else:
                self.record("E504", self.doc.key_span(kptr),
                            f"{self.where(ptr)}: unknown key \"{key}\"", hint)
        for key in required:
            if key not in value:
                self.fail("E505", self.head(ptr), f"{self.where(ptr)}: missing \"{key}\"",
                          f"add \"{key}\": ... to this object")
        return value

    def mapping(self, ptr: str, value: Any, what: str) -> dict:
        """An object used as a map (any keys), e.g. joint name -> value."""
        if not isinstance(value, dict):
            self.type_error(ptr, value, what)
        return value

    def number(self, ptr: str, value: Any) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.type_error(ptr, value, "a number")
        if not math.isfinite(value):
            self.fail("E506", self.span(ptr), f"{ptr}: the number is too large")
        return float(value)

    def integer(self, ptr: str, value: Any, minimum: int | None = 0) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            if isinstance(value, float) and value.is_integer():
                value = int(value)
            else:
                self.type_error(ptr, value, "a whole number")
        if minimum is not None and value < minimum:
            self.fail("E512", self.span(ptr), f"{ptr}: {value} is less than {minimum}")
        return value

    def string(self, ptr: str, value: Any, nonempty: bool = True) -> str:
        if not isinstance(value, str):
            self.type_error(ptr, value, "a string")
        if nonempty and not value.strip():
            self.fail("E506", self.span(ptr), f"{ptr}: expected a non-empty string")
        return value

    def boolean(self, ptr: str, value: Any) -> bool:
        if not isinstance(value, bool):
            hint = "write true or false without quotes" if isinstance(value, str) else None
            self.type_error(ptr, value, "true or false", hint)
        return value

    def array(self, ptr: str, value: Any, what: str = "an array") -> list:
        if not isinstance(value, list):
            self.type_error(ptr, value, what)
        return value

    def numbers(self, ptr: str, value: Any, n: int, what: str) -> tuple[float, ...]:
        """An array of exactly ``n`` numbers (``what`` names it in the messages)."""
        if not isinstance(value, list):
            self.type_error(ptr, value, f"{what}: an array of {n} numbers")
        if len(value) != n:
            example = "[0, 0, 0, 1]" if n == 4 else "[" + ", ".join(["0.0"] * n) + "]"
            self.fail("E507", self.span(ptr), f"{ptr}: {what} needs {n} numbers, found "
                      f"{len(value)}", f"write {n} numbers, like {example}")
        return tuple(self.number(f"{ptr}/{i}", v) for i, v in enumerate(value))

    def positive(self, ptr: str, x: float, what: str, allow_zero: bool = False) -> float:
        if x < 0 or (x == 0 and not allow_zero):
            self.fail("E512", self.span(ptr), f"{ptr}: {what} must be "
                      f"{'zero or more' if allow_zero else 'positive'}, found {fmt_num(x)}",
                      "sizes are lengths in metres: " + ("half-extents are half the box's "
                                                        "size along each axis" if "half" in what
                                                        else "use a positive value"))
        return x

    def interval(self, ptr: str, value: Any, what: str) -> tuple[float, float]:
        lo, hi = self.numbers(ptr, value, 2, what)
        if lo > hi:
            self.fail("E511", self.span(ptr), f"{ptr}: {what} is empty: low {fmt_num(lo)} > "
                      f"high {fmt_num(hi)}", "write the interval as [low, high]")
        return lo, hi

    def bounds(self, ptr: str, value: Any) -> tuple[tuple[float, float], ...]:
        rows = self.array(ptr, value, "[[xlo, xhi], [ylo, yhi], [zlo, zhi]]")
        if len(rows) != 3:
            self.fail("E507", self.span(ptr), f"{ptr}: workspace bounds need 3 intervals "
                      f"(x, y, z), found {len(rows)}", "write [[xlo, xhi], [ylo, yhi], [zlo, zhi]]")
        return tuple(self.interval(f"{ptr}/{i}", r, f"the {'xyz'[i]} bound")
                     for i, r in enumerate(rows))

    def quaternion(self, ptr: str, value: Any) -> Quat:
        q = self.numbers(ptr, value, 4, "a rotation (quaternion x, y, z, w)")
        norm = math.sqrt(sum(c * c for c in q))
        if abs(norm - 1.0) > ROTATION_TOLERANCE:
            self.fail("E508", self.span(ptr), f"{ptr}: the quaternion {list(q)} has norm "
                      f"{fmt_num(norm)}, not 1 (tolerance {ROTATION_TOLERANCE:g})",
                      "a rotation is a unit quaternion in x, y, z, w order; no rotation is "
                      "[0, 0, 0, 1], a quarter turn about z is [0, 0, 0.7071068, 0.7071068]")
        return unit_quat(q)

    def pose(self, ptr: str, value: Any, rotation_required: bool) -> Pose:
        req = ("translation", "rotation") if rotation_required else ("translation",)
        opt = () if rotation_required else ("rotation",)
        v = self.obj(ptr, value, req, opt, what='a pose {"translation": [...], "rotation": [...]}')
        t = self.numbers(f"{ptr}/translation", v["translation"], 3, "a translation")
        q = self.quaternion(f"{ptr}/rotation", v["rotation"]) if "rotation" in v \
            else (0.0, 0.0, 0.0, 1.0)
        return Pose((t[0], t[1], t[2]), q)

    def pddl_name(self, ptr: str, value: Any) -> str:
        s = self.string(ptr, value)
        if re.search(r"[\s()\";]", s):
            self.fail("E518", self.span(ptr), f"{ptr}: \"{s}\" cannot be used as a name in PDDL",
                      "names have no spaces, brackets, quotes or `;`")
        return s


def read_json_scene(source: SourceFile, doc: JsonDoc | None, report: LoadReport, legacy: bool,
                    build) -> Scene:
    """Run ``build(reader)`` over a JSON scene, collecting every problem before raising."""
    r = JsonReader(doc or parse_json(source), report, legacy=legacy)
    scene = None
    with r.part():
        scene = build(r)
    r.finish()
    assert scene is not None
    return scene
