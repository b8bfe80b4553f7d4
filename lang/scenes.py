"""Scene loaders: native tmpc JSON, tmit-star JSON and planet (Lagriffoul) XML -> :class:`Scene`.

:data:`SCENE_LOADERS` maps a format name to its loader; :func:`load_scene` reads a file, detects
its format (or takes ``fmt``) and returns the checked :class:`~tmpc.lang.scene.Scene`. Every
problem a user can cause is a :class:`~tmpc.lang.diagnostics.SceneError` whose diagnostics name
the file and the JSON pointer or XML element and carry a span; independent problems (one per
object) are reported together. Warnings (legacy keys tmpc ignores, meshes not found with
``strict_meshes=False``) go to an optional :class:`LoadReport`.

Conventions (docs/world.md): metres, radians, quaternions **xyzw**, box half-extents, support
regions in the object's own frame. Relative paths in the native format are relative to the scene
file's directory; in the legacy formats, to the scene file's directory or any of its ancestors
(planet and tmit-star ran from their repository roots), the first that exists winning.
"""

from __future__ import annotations

import difflib
import math
import os
import re
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, NoReturn

from .diagnostics import Diagnostic, Related, SceneError, error, warning
from .jsonpos import JsonDoc, parse_json, pointer
from .scene import Box, Origin, Pose, Quat, RobotSpec, Scene, SceneObject, Shape, Vec3
from .source import SourceFile, Span

__all__ = ["SCENE_LOADERS", "NATIVE_SCENE_FORMAT", "LoadReport", "SceneOptions",
           "detect_scene_format", "load_scene", "load_allowed_pairs", "urdf_names"]

NATIVE_SCENE_FORMAT = "tmpc-scene/1"
#: |norm - 1| allowed for a quaternion (it is normalised) and for R Rᵀ - I of a rotation matrix
ROTATION_TOLERANCE = 1e-3


# ============================================================================================
# Shared machinery: reports, error collection, files


@dataclass
class LoadReport:
    """What a load leaves besides its result: warnings and the files their spans point into."""

    warnings: list[Diagnostic] = field(default_factory=list)
    files: dict[str, SourceFile] = field(default_factory=dict)


@dataclass(frozen=True)
class SceneOptions:
    """How to find meshes. ``mesh_dir``: planet's ``objdir`` (XML ``<geom>`` paths are relative
    to it). ``mesh_fallback_dirs``: more places to look for a mesh, by its relative path and by
    its file name. ``strict_meshes=False`` turns a missing mesh into a warning (W501)."""

    mesh_dir: Path | None = None
    strict_meshes: bool = True
    mesh_fallback_dirs: tuple[Path, ...] = ()


class _Stop(Exception):
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
    """Error collection for one file. ``fail`` records an error and raises :class:`_Stop`;
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
        raise _Stop

    def record(self, code: str, span: Span | None, message: str, hint: str | None = None,
               related: Iterable[Related] = ()) -> None:
        try:
            self.fail(code, span, message, hint, related)
        except _Stop:
            pass

    def warn(self, code: str, span: Span | None, message: str, hint: str | None = None) -> None:
        self.report.warnings.append(warning(code, f"{self.name}: {message}", span, hint))

    @contextmanager
    def part(self) -> Iterator[None]:
        try:
            yield
        except _Stop:
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
        raise SceneError(error("E011", f"{key} is not UTF-8 text (byte {exc.start})", None,
                               f"save the {what} file as UTF-8")) from None
    except OSError as exc:
        raise SceneError(error("E010", f"cannot read {what} file {key}: {exc.strerror}",
                               None)) from None


def search_dirs(start: Path, ancestors: bool) -> list[Path]:
    """``start`` and, for legacy files, each of its ancestors (nearest first)."""
    return [start, *start.parents] if ancestors else [start]


def find_file(raw: str, bases: Iterable[Path], by_name: Iterable[Path] = (),
              want_dir: bool = False) -> tuple[Path | None, list[Path]]:
    """Resolve ``raw`` (``~`` expanded): absolute as is; relative against each base in turn,
    then by file name in ``by_name``. Returns (the first that exists, every place tried)."""
    p = Path(os.path.expanduser(raw))
    candidates = [p] if p.is_absolute() else [b / p for b in bases]
    candidates += [d / p.name for d in by_name]
    tried: list[Path] = []
    for c in candidates:
        c = Path(os.path.normpath(c))
        if c in tried:
            continue
        tried.append(c)
        if (c.is_dir() if want_dir else c.is_file()):
            return c, tried
    return None, tried


def tried_text(tried: list[Path], limit: int = 6) -> str:
    shown = [str(t) for t in tried[:limit]]
    more = f" and {len(tried) - limit} more" if len(tried) > limit else ""
    return "looked for " + ", ".join(shown) + more


# ============================================================================================
# Rotations


def quat_from_matrix(r: list[list[float]]) -> Quat:
    """Unit quaternion (xyzw) of a rotation matrix (Shepperd's method, then normalised)."""
    tr = r[0][0] + r[1][1] + r[2][2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        q = ((r[2][1] - r[1][2]) / s, (r[0][2] - r[2][0]) / s, (r[1][0] - r[0][1]) / s, s / 4)
    elif r[0][0] > r[1][1] and r[0][0] > r[2][2]:
        s = math.sqrt(1.0 + r[0][0] - r[1][1] - r[2][2]) * 2
        q = (s / 4, (r[0][1] + r[1][0]) / s, (r[0][2] + r[2][0]) / s, (r[2][1] - r[1][2]) / s)
    elif r[1][1] > r[2][2]:
        s = math.sqrt(1.0 + r[1][1] - r[0][0] - r[2][2]) * 2
        q = ((r[0][1] + r[1][0]) / s, s / 4, (r[1][2] + r[2][1]) / s, (r[0][2] - r[2][0]) / s)
    else:
        s = math.sqrt(1.0 + r[2][2] - r[0][0] - r[1][1]) * 2
        q = ((r[0][2] + r[2][0]) / s, (r[1][2] + r[2][1]) / s, s / 4, (r[1][0] - r[0][1]) / s)
    if q[3] < 0:          # a canonical sign: w >= 0
        q = (-q[0], -q[1], -q[2], -q[3])
    n = math.sqrt(sum(c * c for c in q))
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


def matrix_from_quat(q: Quat) -> list[list[float]]:
    x, y, z, w = q
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def orthonormality_error(r: list[list[float]]) -> tuple[float, float]:
    """(max |R Rᵀ - I|, det R)."""
    dev = max(abs(sum(r[i][k] * r[j][k] for k in range(3)) - (i == j))
              for i in range(3) for j in range(3))
    det = (r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
           - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
           + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]))
    return dev, det


def box_to_object_frame(q: Quat, lower: Vec3, upper: Vec3) -> tuple[Box, bool]:
    """A box given in world-aligned axes at an object's origin, expressed in the object's frame
    (Rᵀ applied). Exact (returns True) when R maps axes to axes; otherwise the axis-aligned
    bounding box of the rotated box (returns False)."""
    rt = [list(row) for row in zip(*matrix_from_quat(q))]     # Rᵀ
    perm = all(min(abs(v), abs(abs(v) - 1)) < 1e-6 for row in rt for v in row)
    lo, hi = [0.0] * 3, [0.0] * 3
    for i in range(3):
        if perm:
            j = max(range(3), key=lambda k: abs(rt[i][k]))
            a, b = (lower[j], upper[j]) if rt[i][j] > 0 else (-upper[j], -lower[j])
            lo[i], hi[i] = a + 0.0, b + 0.0
        else:
            lo[i] = sum(min(rt[i][k] * lower[k], rt[i][k] * upper[k]) for k in range(3))
            hi[i] = sum(max(rt[i][k] * lower[k], rt[i][k] * upper[k]) for k in range(3))
    return Box((lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2])), perm


# ============================================================================================
# URDF names (for checking joint, parent and collision-pair names; the URDF itself is loaded
# by the robot model code)


@dataclass(frozen=True)
class UrdfNames:
    robot: str
    links: frozenset[str]
    joints: frozenset[str]
    #: joints a planner can move: revolute, continuous or prismatic, and not mimics
    movable: frozenset[str] = frozenset()


_URDF_CACHE: dict[tuple[str, int, int], UrdfNames] = {}


def urdf_names(path: Path, report: LoadReport | None = None) -> UrdfNames:
    """The robot, link and joint names of a URDF (a fast expat scan, cached per file version).
    A file that is not well-formed XML is SceneError E561 (the URDF's own code)."""
    st = path.stat()
    key = (str(path), st.st_mtime_ns, st.st_size)
    hit = _URDF_CACHE.get(key)
    if hit is not None:
        return hit
    source = read_source(path, "URDF")
    root = parse_xml(source, report or LoadReport(), code="E561")
    links = frozenset(c.attrib["name"] for c in root.children
                      if c.tag == "link" and "name" in c.attrib)
    joint_nodes = [c for c in root.children if c.tag == "joint" and "name" in c.attrib]
    movable = frozenset(j.attrib["name"] for j in joint_nodes
                        if j.attrib.get("type") in ("revolute", "continuous", "prismatic")
                        and j.child("mimic") is None)
    names = UrdfNames(root.attrib.get("name", "robot"), links,
                      frozenset(j.attrib["name"] for j in joint_nodes), movable)
    if len(_URDF_CACHE) > 32:
        _URDF_CACHE.clear()
    _URDF_CACHE[key] = names
    return names


# ============================================================================================
# XML with positions (expat: stdlib, exact line and column for every element)


@dataclass(eq=False)
class XmlNode:
    tag: str
    attrib: dict[str, str]
    start: int                       # offset of `<`
    tag_end: int = 0                 # offset just past the start tag's `>`
    text: str = ""                   # stripped character data directly inside
    content: tuple[int, int] | None = None   # span of that text in the file
    children: list["XmlNode"] = field(default_factory=list)
    parent: "XmlNode | None" = None

    @property
    def path(self) -> str:
        """XPath-like location for messages: ``/problem/objects/obj[3]/pose``."""
        if self.parent is None:
            return "/" + self.tag
        same = [c for c in self.parent.children if c.tag == self.tag]
        index = f"[{same.index(self) + 1}]" if len(same) > 1 else ""
        return f"{self.parent.path}/{self.tag}{index}"

    def child(self, tag: str) -> "XmlNode | None":
        return next((c for c in self.children if c.tag == tag), None)

    def all(self, tag: str) -> list["XmlNode"]:
        return [c for c in self.children if c.tag == tag]


def parse_xml(source: SourceFile, report: LoadReport, code: str = "E501") -> XmlNode:
    """Parse XML keeping each element's position. Malformed XML is SceneError ``code``."""
    from xml.parsers import expat

    text = source.text
    data = text.encode("utf-8")
    ascii_only = len(data) == len(text)

    cursor = [0, 0]     # (byte, char) of the last conversion: expat's indices only grow

    def char_offset(byte_index: int) -> int:
        if ascii_only:
            return byte_index
        b, c = cursor if byte_index >= cursor[0] else (0, 0)
        c += len(data[b:byte_index].decode("utf-8", "replace"))
        cursor[:] = [byte_index, c]
        return c

    parser = expat.ParserCreate()
    stack: list[XmlNode] = []
    chunks: list[list[str]] = []
    roots: list[XmlNode] = []

    def start(tag: str, attrib: dict[str, str]) -> None:
        pos = char_offset(parser.CurrentByteIndex)
        node = XmlNode(tag, attrib, pos)
        node.tag_end = text.find(">", pos) + 1 or pos + 1
        if stack:
            node.parent = stack[-1]
            stack[-1].children.append(node)
        else:
            roots.append(node)
        stack.append(node)
        chunks.append([])

    def chars(s: str) -> None:
        chunks[-1].append(s)

    def end(tag: str) -> None:
        node = stack.pop()
        node.text = "".join(chunks.pop()).strip()
        if node.text and not node.children:
            end_pos = char_offset(parser.CurrentByteIndex)
            raw = text[node.tag_end:end_pos]
            lead = len(raw) - len(raw.lstrip())
            node.content = (node.tag_end + lead, node.tag_end + len(raw.rstrip()))

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = chars
    try:
        parser.Parse(data, True)
    except expat.ExpatError as exc:
        line = exc.lineno or 1
        pos = source.offset(line, (exc.offset or 0) + 1)
        back = text.rfind("<", max(0, pos - 2), pos + 1)   # expat may point past `</`
        pos = back if back != -1 else pos
        raise SceneError(error(
            code, f"{display_name(source.path)}: malformed XML: "
            f"{expat.errors.messages.get(exc.code, str(exc))}", Span(source.path, pos, pos + 1),
            "check that every <tag> has its </tag> and that & is written &amp;"),
            {**report.files, source.path: source}) from None
    return roots[0]


# ============================================================================================
# Typed access to JSON values (shared by the two JSON formats and the tmit-star spec)


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
        return (q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm)

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


# ============================================================================================
# Files a scene refers to: URDFs and meshes


def _uri_candidates(raw: str, bases: list[Path]) -> list[Path] | None:
    """Candidates for a ``package://`` or ``file://`` reference (None for a plain path)."""
    if not raw.startswith(("package://", "file://")):
        return None
    from .robot import resolve_uri       # the robot model's resolver (no heavy imports)
    return resolve_uri(raw, bases[0])


def _find(raw: str, bases: list[Path], by_name: Iterable[Path] = ()) -> tuple[Path | None,
                                                                             list[Path]]:
    uri = _uri_candidates(raw, bases)
    if uri is None:
        return find_file(raw, bases, by_name)
    tried = [Path(os.path.normpath(c)) for c in uri]
    return next((c for c in tried if c.is_file()), None), tried


def _resolve_urdf(r: Reader, raw: str, span: Span | None, where: str) -> tuple[Path, UrdfNames]:
    found, tried = _find(raw, search_dirs(r.directory, r.legacy))
    if found is None:
        r.fail("E560", span, f"{where}: URDF file \"{raw}\" not found",
               join_hints(tried_text(tried), "relative paths are relative to the scene file's "
                          "directory" + (" or one of its parents" if r.legacy else "")))
    try:
        return found, urdf_names(found, r.report)
    except SceneError as exc:       # a malformed URDF: its own file and position
        r.errors.extend(exc.diagnostics)
        r.report.files.update(exc.files)
        raise _Stop from None


def _resolve_mesh(r: Reader, opts: SceneOptions, raw: str, span: Span | None, where: str,
                  bases: list[Path]) -> Path:
    fallbacks = list(opts.mesh_fallback_dirs)
    found, tried = _find(raw, bases + fallbacks, by_name=fallbacks)
    if found is not None:
        return found
    looked = tried_text(tried)
    if opts.strict_meshes:
        r.fail("E514", span, f"{where}: mesh file \"{raw}\" not found",
               join_hints(looked, "point tmpc at the meshes (a mesh directory / fallback "
                           "directories) or load with strict meshes off to go on without them"))
    guess = next((t for t in tried if t.parent.is_dir()), tried[0])
    r.warn("W501", span, f"{where}: mesh file \"{raw}\" not found; kept as {guess}",
           join_hints(looked, "collision checks need the mesh; give a mesh directory"))
    return guess


# ============================================================================================
# Checks across a whole scene: names, parents, collision pairs


@dataclass
class _Entry:
    """An object as loaded plus where its name and parent were written."""

    obj: SceneObject
    name_span: Span | None
    parent_span: Span | None = None


def _check_names(r: Reader, entries: list[_Entry], robot: RobotSpec | None,
                 urdf: UrdfNames | None) -> None:
    first: dict[str, _Entry] = {}
    for e in entries:
        key = e.obj.name.lower()
        if key in first:
            r.record("E510", e.name_span, f"object name \"{e.obj.name}\" used twice",
                     "names are compared without case (PDDL is case-insensitive); rename one",
                     [Related(first[key].name_span, "first used here")]
                     if first[key].name_span else [])
        else:
            first[key] = e
    frames = _frame_names(entries, robot, urdf)
    for e in entries:
        p = e.obj.parent
        if p is None:
            continue
        if p.lower() == e.obj.name.lower():
            r.record("E513", e.parent_span, f"object \"{e.obj.name}\" is its own parent")
        elif p.lower() not in frames:
            r.record("E513", e.parent_span, f"object \"{e.obj.name}\": unknown parent \"{p}\"",
                     join_hints(did_you_mean(p, frames.values()), "a parent is another object, "
                                 "the robot, or one of the robot's links or joints"))
    _check_cycles(r, entries, first)


def _frame_names(entries: list[_Entry], robot: RobotSpec | None,
                 urdf: UrdfNames | None) -> dict[str, str]:
    """Every name a pose can be relative to or a collision pair can mention (lower -> as written)."""
    names = [e.obj.name for e in entries]
    if robot is not None:
        names.append(robot.name)
    if urdf is not None:
        names += [*urdf.links, *urdf.joints, urdf.robot]
    return {n.lower(): n for n in names}


def _check_cycles(r: Reader, entries: list[_Entry], by_name: dict[str, _Entry]) -> None:
    reported: set[str] = set()
    for e in entries:
        chain, cur = [e.obj.name], e
        while cur.obj.parent and cur.obj.parent.lower() in by_name:
            nxt = by_name[cur.obj.parent.lower()]
            if nxt.obj.name.lower() == e.obj.name.lower():
                if not reported & {c.lower() for c in chain}:
                    r.record("E513", e.parent_span, "parents form a loop: "
                             + " -> ".join(chain + [e.obj.name]), "one of them must be placed in "
                             "the world or on the robot")
                reported.add(e.obj.name.lower())
                break
            if nxt.obj.name in chain or len(chain) > len(entries):
                break
            chain.append(nxt.obj.name)
            cur = nxt


def _check_pairs(r: Reader, pairs: list[tuple[str, str, Span | None]],
                 frames: dict[str, str]) -> tuple[tuple[str, str], ...]:
    out: list[tuple[str, str]] = []
    for a, b, span in pairs:
        for n in (a, b):
            if n.lower() not in frames:
                r.record("E513", span, f"allowed collision names \"{n}\", which is no object, "
                         "robot link or joint", join_hints(did_you_mean(n, frames.values())))
        if (a, b) not in out and (b, a) not in out:
            out.append((a, b))
    return tuple(out)


# ============================================================================================
# Native tmpc scene JSON


def _load_native(source: SourceFile, opts: SceneOptions, report: LoadReport,
                 doc: JsonDoc | None = None) -> Scene:
    r = JsonReader(doc or parse_json(source), report, legacy=False)
    scene = None
    with r.part():
        scene = _native_scene(r, opts)
    r.finish()
    assert scene is not None
    return scene


def _native_scene(r: JsonReader, opts: SceneOptions) -> Scene:
    top = r.obj("", r.doc.value, ("format", "bounds"), ("robot", "objects", "allowed_collisions"),
                what='a scene: {"format": "tmpc-scene/1", ...}')
    fmt = r.string("/format", top["format"])
    if fmt != NATIVE_SCENE_FORMAT:
        r.fail("E519", r.span("/format"), f"/format: unknown scene format \"{fmt}\"",
               f"this version of tmpc reads \"{NATIVE_SCENE_FORMAT}\"")
    bounds = robot = urdf = None
    with r.part():
        bounds = r.bounds("/bounds", top["bounds"])
    if top.get("robot") is not None:
        with r.part():
            robot, urdf = _native_robot(r, "/robot", top["robot"])
    entries: list[_Entry] = []
    with r.part():
        for i, o in enumerate(r.array("/objects", top.get("objects", []))):
            with r.part():
                entries.append(_native_object(r, f"/objects/{i}", o, opts))
    _check_names(r, entries, robot, urdf)
    pairs: tuple[tuple[str, str], ...] = ()
    if "allowed_collisions" in top:
        with r.part():
            pairs = _native_pairs(r, top["allowed_collisions"], _frame_names(entries, robot, urdf))
    r.finish()
    return Scene(r.source.path, bounds, robot, tuple(e.obj for e in entries), pairs,  # type: ignore[arg-type]
                 "tmpc-json")


def _native_robot(r: JsonReader, ptr: str, value: Any) -> tuple[RobotSpec, UrdfNames]:
    v = r.obj(ptr, value, ("urdf",), ("name", "base_pose", "mobile_base", "joints",
                                     "controllable"))
    raw = r.string(f"{ptr}/urdf", v["urdf"])
    path, names = _resolve_urdf(r, raw, r.span(f"{ptr}/urdf"), f"{ptr}/urdf")
    name = r.pddl_name(f"{ptr}/name", v["name"]) if "name" in v else names.robot
    pose = r.pose(f"{ptr}/base_pose", v["base_pose"], False) if "base_pose" in v else Pose()
    mobile = r.boolean(f"{ptr}/mobile_base", v.get("mobile_base", False))
    joints: list[tuple[str, float]] = []
    jv = r.mapping(f"{ptr}/joints", v.get("joints", {}), "an object {joint name: value}")
    for jn, x in jv.items():
        jp = f"{ptr}/joints" + pointer(jn)
        with r.part():
            _known_joint(r, jn, names, r.doc.key_span(jp), f"{ptr}/joints")
            joints.append((jn, r.number(jp, x)))
    controllable = None
    if v.get("controllable") is not None:
        controllable = _native_controllable(r, f"{ptr}/controllable", v["controllable"], names)
    return RobotSpec(path, pose, mobile, tuple(joints), controllable, name,
                     r.origin(r.span(ptr), ptr)), names


def _known_joint(r: Reader, joint: str, names: UrdfNames, span: Span | None, where: str,
                 warn: bool = False, movable: bool = False) -> bool:
    """Is ``joint`` a joint of the URDF (``movable``: one a planner can move)? Else E564 (or,
    for legacy joint values, warning W502 and the value is dropped)."""
    if joint in (names.movable if movable else names.joints):
        return True
    what = "has no joint" if joint not in names.joints else "has as a fixed or mimic joint"
    msg = f"{where}: the URDF ({names.robot}) {what} \"{joint}\""
    hint = did_you_mean(joint, names.movable if movable else names.joints)
    if warn:
        r.warn("W502", span, msg + " (ignored)", hint)
        return False
    r.fail("E564", span, msg, hint)


def _native_controllable(r: JsonReader, ptr: str, value: Any, names: UrdfNames) -> tuple[str, ...]:
    out: list[str] = []
    for i, jn in enumerate(r.array(ptr, value, "an array of joint names")):
        with r.part():
            jn = r.string(f"{ptr}/{i}", jn)
            if jn in out:
                r.fail("E510", r.span(f"{ptr}/{i}"), f"{ptr}/{i}: joint \"{jn}\" listed twice")
            _known_joint(r, jn, names, r.span(f"{ptr}/{i}"), ptr, movable=True)
            out.append(jn)
    return tuple(out)


_SHAPE_KEYS = {"box": (("half_extents",), ()), "sphere": (("radius",), ()),
               "cylinder": (("radius", "length"), ()), "mesh": (("file",), ("scale", "convex"))}


def _native_object(r: JsonReader, ptr: str, value: Any, opts: SceneOptions) -> _Entry:
    v = r.obj(ptr, value, ("name", "pose"), ("movable", "shape", "support", "parent"))
    name = r.pddl_name(f"{ptr}/name", v["name"])
    pose = r.pose(f"{ptr}/pose", v["pose"], False)
    movable = r.boolean(f"{ptr}/movable", v.get("movable", False))
    shape = _native_shape(r, f"{ptr}/shape", v["shape"], opts) \
        if v.get("shape") is not None else None
    support = None
    if v.get("support") is not None:
        sp = r.obj(f"{ptr}/support", v["support"], ("lower", "upper"))
        lo = r.numbers(f"{ptr}/support/lower", sp["lower"], 3, "a support region's lower corner")
        hi = r.numbers(f"{ptr}/support/upper", sp["upper"], 3, "a support region's upper corner")
        for i in range(3):
            if lo[i] > hi[i]:
                r.fail("E511", r.span(f"{ptr}/support/upper/{i}"), f"{ptr}/support: upper "
                       f"{'xyz'[i]} {fmt_num(hi[i])} is below lower {fmt_num(lo[i])}",
                       "the support region is the box from lower to upper, in the object's frame",
                       [Related(r.span(f"{ptr}/support/lower/{i}"), "lower bound")])
        support = Box((lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2]))
    parent = r.pddl_name(f"{ptr}/parent", v["parent"]) if v.get("parent") is not None else None
    obj = SceneObject(name, pose, movable, shape, support, parent, r.origin(r.span(ptr), ptr))
    return _Entry(obj, r.span(f"{ptr}/name"), r.span(f"{ptr}/parent") if parent else None)


def _native_shape(r: JsonReader, ptr: str, value: Any, opts: SceneOptions) -> Shape:
    if not isinstance(value, dict):
        r.type_error(ptr, value, 'a shape {"type": "box" | "sphere" | "cylinder" | "mesh", ...}')
    if "type" not in value:
        r.fail("E505", r.head(ptr), f"{ptr}: missing \"type\"",
               'add "type": "box" (or "sphere", "cylinder", "mesh")')
    t = r.string(f"{ptr}/type", value["type"])
    if t not in _SHAPE_KEYS:
        r.fail("E517", r.span(f"{ptr}/type"), f"{ptr}/type: unknown shape type \"{t}\"",
               join_hints(did_you_mean(t, _SHAPE_KEYS), "the types are box, sphere, cylinder "
                           "and mesh"))
    req, opt = _SHAPE_KEYS[t]
    v = r.obj(ptr, value, ("type", *req), opt)
    num = lambda k, what: r.positive(f"{ptr}/{k}", r.number(f"{ptr}/{k}", v[k]), what)  # noqa: E731
    if t == "box":
        he = r.numbers(f"{ptr}/half_extents", v["half_extents"], 3, "half-extents")
        for i, x in enumerate(he):
            r.positive(f"{ptr}/half_extents/{i}", x, "a half-extent", allow_zero=True)
        return Shape("box", size=(he[0], he[1], he[2]))
    if t == "sphere":
        return Shape("sphere", radius=num("radius", "a radius"))
    if t == "cylinder":
        return Shape("cylinder", radius=num("radius", "a radius"), length=num("length", "a length"))
    raw = r.string(f"{ptr}/file", v["file"])
    bases = [r.directory] + ([opts.mesh_dir] if opts.mesh_dir else [])
    mesh = _resolve_mesh(r, opts, raw, r.span(f"{ptr}/file"), f"{ptr}/file", bases)
    scale: tuple[float, ...] = (1.0, 1.0, 1.0)
    if "scale" in v:
        sv = v["scale"]
        scale = (r.number(f"{ptr}/scale", sv),) * 3 if not isinstance(sv, list) \
            else r.numbers(f"{ptr}/scale", sv, 3, "a scale")
        for i, x in enumerate(scale):
            r.positive(f"{ptr}/scale" + (f"/{i}" if isinstance(sv, list) else ""), x, "a scale")
    convex = r.boolean(f"{ptr}/convex", v.get("convex", False))
    return Shape("mesh", mesh=mesh, scale=(scale[0], scale[1], scale[2]), convex=convex)


def _native_pairs(r: JsonReader, value: Any, frames: dict[str, str]) -> tuple[tuple[str, str], ...]:
    ptr = "/allowed_collisions"
    if isinstance(value, str):
        found, tried = find_file(value, [r.directory])
        if found is None:
            r.fail("E515", r.span(ptr), f"{ptr}: allowed-collision file \"{value}\" not found",
                   tried_text(tried))
        return load_allowed_pairs(found, r.report)
    pairs: list[tuple[str, str, Span | None]] = []
    for i, p in enumerate(r.array(ptr, value, 'an array of name pairs [["a", "b"], ...] or a '
                                              'CSV file name')):
        with r.part():
            if not isinstance(p, list) or len(p) != 2:
                r.fail("E507", r.span(f"{ptr}/{i}"), f"{ptr}/{i}: expected a pair of names "
                       "[\"a\", \"b\"]", 'write ["link_or_object", "other"]')
            pairs.append((r.string(f"{ptr}/{i}/0", p[0]), r.string(f"{ptr}/{i}/1", p[1]),
                          r.span(f"{ptr}/{i}")))
    return _check_pairs(r, pairs, frames)


# ============================================================================================
# tmit-star scene JSON (FACTS 4.2)

_TMIT_IGNORED = ("color", "specular", "hide_name")


def _load_tmit(source: SourceFile, opts: SceneOptions, report: LoadReport,
               doc: JsonDoc | None = None) -> Scene:
    r = JsonReader(doc or parse_json(source), report, legacy=True)
    scene = None
    with r.part():
        scene = _tmit_scene(r, opts)
    r.finish()
    assert scene is not None
    return scene


def _tmit_scene(r: JsonReader, opts: SceneOptions) -> Scene:
    top = r.obj("", r.doc.value, ("bounds", "robot"), ("objects",))
    bounds = robot = urdf = None
    with r.part():
        bounds = r.bounds("/bounds", top["bounds"])
    with r.part():
        robot, urdf = _tmit_robot(r, "/robot", top["robot"])
    entries: list[_Entry] = []
    with r.part():
        for i, o in enumerate(r.array("/objects", top.get("objects", []))):
            with r.part():
                entries.append(_tmit_object(r, f"/objects/{i}", o, opts))
    _check_names(r, entries, robot, urdf)
    r.finish()
    return Scene(r.source.path, bounds, robot, tuple(e.obj for e in entries), (),  # type: ignore[arg-type]
                 "tmit-star-json")


def _tmit_robot(r: JsonReader, ptr: str, value: Any) -> tuple[RobotSpec, UrdfNames]:
    v = r.obj(ptr, value, ("urdf", "base_pose"), ("joint_poses",))
    raw = r.string(f"{ptr}/urdf", v["urdf"])
    path, names = _resolve_urdf(r, raw, r.span(f"{ptr}/urdf"), f"{ptr}/urdf")
    bp = r.obj(f"{ptr}/base_pose", v["base_pose"], ("translation", "rotation"))
    x, y = r.numbers(f"{ptr}/base_pose/translation", bp["translation"], 2,
                     "a tmit-star base translation [x, y]")
    yaw = r.number(f"{ptr}/base_pose/rotation", bp["rotation"])
    joints: list[tuple[str, float]] = []
    jv = r.mapping(f"{ptr}/joint_poses", v.get("joint_poses", {}), "an object {joint: value}")
    for jn, val in jv.items():
        jp = f"{ptr}/joint_poses" + pointer(jn)
        with r.part():
            x_j = r.number(jp, val)
            if _known_joint(r, jn, names, r.doc.key_span(jp), f"{ptr}/joint_poses", warn=True):
                joints.append((jn, x_j))
    # tmit-star's base always moves in x, y, yaw; it plans every joint of the URDF
    return RobotSpec(path, Pose.from_xyz_yaw(x, y, 0.0, yaw), True, tuple(joints), None,
                     names.robot, r.origin(r.span(ptr), ptr)), names


def _tmit_object(r: JsonReader, ptr: str, value: Any, opts: SceneOptions) -> _Entry:
    v = r.obj(ptr, value, ("name", "pose"), ("is_static", "parent_name", "surface_bounds",
                                             "obj_file", "scale", "is_concave", "shape"),
              ignored=_TMIT_IGNORED)
    name = r.pddl_name(f"{ptr}/name", v["name"])
    pose = r.pose(f"{ptr}/pose", v["pose"], True)
    movable = not r.boolean(f"{ptr}/is_static", v.get("is_static", True))
    parent = r.pddl_name(f"{ptr}/parent_name", v["parent_name"]) if "parent_name" in v else None
    shape = _tmit_shape(r, ptr, v, opts)
    support = None
    if "surface_bounds" in v:
        sp = f"{ptr}/surface_bounds"
        sb = r.obj(sp, v["surface_bounds"], ("x", "y", "z"))
        (xl, xh), (yl, yh), (zl, zh) = (r.interval(f"{sp}/{a}", sb[a], f"the {a} range")
                                        for a in "xyz")
        # tmit-star adds these to the object's position without rotating them: they are in
        # world-aligned axes at the object's origin. The model keeps the object's frame.
        support, exact = box_to_object_frame(pose.rotation, (xl, yl, zl), (xh, yh, zh))
        if not exact:
            r.warn("W504", r.span(sp), f"{sp}: the object's rotation does not map axes to axes; "
                   "its support region is approximated by a larger box in the object's frame",
                   "tmit-star bounds are world-aligned; give the region in the object's frame "
                   "in a native scene to be exact")
    obj = SceneObject(name, pose, movable, shape, support, parent, r.origin(r.span(ptr), ptr))
    return _Entry(obj, r.span(f"{ptr}/name"),
                  r.span(f"{ptr}/parent_name") if parent else None)


def _tmit_shape(r: JsonReader, ptr: str, v: dict, opts: SceneOptions) -> Shape:
    if "obj_file" in v:
        if "shape" in v:
            r.warn("W503", r.doc.key_span(f"{ptr}/shape"), f"{ptr}: both \"obj_file\" and "
                   "\"shape\" given; \"obj_file\" is used, as tmit-star did", "remove one")
        raw = r.string(f"{ptr}/obj_file", v["obj_file"])
        bases = search_dirs(r.directory, True) + ([opts.mesh_dir] if opts.mesh_dir else [])
        mesh = _resolve_mesh(r, opts, raw, r.span(f"{ptr}/obj_file"), f"{ptr}/obj_file", bases)
        scale = (1.0, 1.0, 1.0)
        if "scale" in v:
            scale = r.numbers(f"{ptr}/scale", v["scale"], 3, "a scale [x, y, z]")
            for i, x in enumerate(scale):
                r.positive(f"{ptr}/scale/{i}", x, "a scale")
        concave = r.boolean(f"{ptr}/is_concave", v.get("is_concave", False))
        return Shape("mesh", mesh=mesh, scale=(scale[0], scale[1], scale[2]), convex=not concave)
    if "shape" in v:
        sp = f"{ptr}/shape"
        s = r.obj(sp, v["shape"], ("type", "extents"))
        t = r.string(f"{sp}/type", s["type"])
        if t != "box":
            r.fail("E517", r.span(f"{sp}/type"), f"{sp}/type: tmit-star shapes are boxes; found "
                   f"\"{t}\"", "use a native tmpc scene for spheres and cylinders, or obj_file")
        he = r.numbers(f"{sp}/extents", s["extents"], 3, "box extents (half-extents)")
        for i, x in enumerate(he):
            r.positive(f"{sp}/extents/{i}", x, "a half-extent", allow_zero=True)
        return Shape("box", size=(he[0], he[1], he[2]))
    r.fail("E505", r.head(ptr), f"{ptr}: object \"{v['name']}\" has no geometry",
           'give "obj_file": "mesh.obj" or "shape": {"type": "box", "extents": [x, y, z]}')


# ============================================================================================
# planet (Lagriffoul benchmark) scene XML (FACTS 4.1)

_PLANET_OBJ_KNOWN = ("name", "geom", "pose", "moveable", "sssp")
_PLANET_OBJ_IGNORED = ("sop", "gf", "gc", "grasps", "attachments")
_PLANET_ROBOT_KNOWN = ("name", "urdf", "basepose", "movebase", "torso", "controllable_joints")
#: planet's <torso> value is this PR2 joint's initial value
TORSO_JOINT = "torso_lift_joint"


class _XmlReader(Reader):
    def start_tag(self, node: XmlNode) -> Span:
        return Span(self.source.path, node.start, node.tag_end)

    def text_span(self, node: XmlNode) -> Span:
        if node.content is not None:
            return Span(self.source.path, *node.content)
        return self.start_tag(node)

    def label(self, node: XmlNode) -> str:
        """``<obj> "table1"`` where the element has a name, else its XML path."""
        owner = node if node.tag in ("obj", "robot") else node.parent
        if owner is not None and owner.tag in ("obj", "robot"):
            nm = owner.child("name")
            if nm is not None and nm.text:
                inner = "" if owner is node else f" <{node.tag}>"
                return f"<{owner.tag}> \"{nm.text}\"{inner}"
        return node.path

    def need(self, node: XmlNode, tag: str) -> XmlNode:
        c = node.child(tag)
        if c is None:
            self.fail("E505", self.start_tag(node), f"{self.label(node)} ({node.path}) has no "
                      f"<{tag}>", f"add <{tag}>...</{tag}> inside <{node.tag}>")
        return c

    def text(self, node: XmlNode) -> str:
        if not node.text:
            self.fail("E505", self.start_tag(node), f"{self.label(node)} is empty",
                      f"write a value between <{node.tag}> and </{node.tag}>")
        return node.text

    def floats(self, node: XmlNode, counts: tuple[int, ...], what: str) -> list[float]:
        parts = self.text(node).split()
        vals = []
        for p in parts:
            try:
                vals.append(float(p))
            except ValueError:
                self.fail("E506", self.text_span(node), f"{self.label(node)}: \"{p}\" is not a "
                          "number", f"{what} is {' or '.join(map(str, counts))} numbers "
                          "separated by spaces")
        if len(vals) not in counts or not all(math.isfinite(x) for x in vals):
            self.fail("E507", self.text_span(node), f"{self.label(node)}: {what} needs "
                      f"{' or '.join(map(str, counts))} numbers, found {len(vals)}")
        return vals

    def boolean(self, node: XmlNode) -> bool:
        t = self.text(node).lower()
        if t.startswith("true"):        # planet compares the first four characters
            return True
        if t.startswith("false"):
            return False
        self.fail("E506", self.text_span(node), f"{self.label(node)}: expected true or false, "
                  f"found \"{node.text}\"")

    def pose(self, node: XmlNode) -> Pose:
        """12 numbers: the rows of [R | t] (a 4th row 0 0 0 1 may follow)."""
        v = self.floats(node, (12, 16), "a pose (the 3x4 matrix [R | t], row by row)")
        if len(v) == 16 and any(abs(a - b) > 1e-9 for a, b in zip(v[12:], (0, 0, 0, 1))):
            self.fail("E509", self.text_span(node), f"{self.label(node)}: the last row of a 4x4 "
                      f"pose must be 0 0 0 1, found {' '.join(map(fmt_num, v[12:]))}")
        rot = [v[0:3], v[4:7], v[8:11]]
        dev, det = orthonormality_error(rot)
        if dev > ROTATION_TOLERANCE or det <= 0:
            what = "is a reflection (determinant < 0)" if det <= 0 and dev <= ROTATION_TOLERANCE \
                else f"is not a rotation: R Rᵀ differs from I by {fmt_num(dev)}"
            self.fail("E509", self.text_span(node), f"{self.label(node)}: the 3x3 part {what} "
                      f"(tolerance {ROTATION_TOLERANCE:g})", "the 12 numbers are r00 r01 r02 tx "
                      "r10 r11 r12 ty r20 r21 r22 tz; the identity pose at (x, y, z) is "
                      "1 0 0 x 0 1 0 y 0 0 1 z")
        return Pose((v[3], v[7], v[11]), quat_from_matrix(rot))

    def check_children(self, node: XmlNode, known: Iterable[str],
                       ignored: Iterable[str] = ()) -> None:
        known, ignored = tuple(known), tuple(ignored)
        for c in node.children:
            if c.tag not in known and c.tag not in ignored:
                self.warn("W500", self.start_tag(c), f"{self.label(node)}: unknown element "
                          f"<{c.tag}> (ignored)", did_you_mean(c.tag, known))


def _load_planet(source: SourceFile, opts: SceneOptions, report: LoadReport,
                 root: XmlNode | None = None) -> Scene:
    root = root or parse_xml(source, report)
    r = _XmlReader(source, report, legacy=True)
    scene = None
    with r.part():
        scene = _planet_scene(r, root, opts)
    r.finish()
    assert scene is not None
    return scene


def _planet_scene(r: _XmlReader, root: XmlNode, opts: SceneOptions) -> Scene:
    r.check_children(root, ("objects", "robots", "workspace_bounds"))
    objects = r.need(root, "objects")
    robots = r.need(root, "robots")
    r.check_children(objects, ("obj",))
    entries: list[_Entry] = []
    mesh_bases = [opts.mesh_dir] if opts.mesh_dir else [r.directory]
    for node in objects.all("obj"):
        with r.part():
            entries.append(_planet_object(r, node, opts, mesh_bases))
    robot = urdf = None
    with r.part():
        robot, urdf = _planet_robot(r, robots)
    bounds = None
    with r.part():
        bounds = _planet_bounds(r, root, entries, robot)
    _check_names(r, entries, robot, urdf)
    r.finish()
    return Scene(r.source.path, bounds, robot, tuple(e.obj for e in entries), (),  # type: ignore[arg-type]
                 "planet-xml")


def _planet_object(r: _XmlReader, node: XmlNode, opts: SceneOptions,
                   mesh_bases: list[Path]) -> _Entry:
    r.check_children(node, _PLANET_OBJ_KNOWN + ("pssp",), _PLANET_OBJ_IGNORED)
    name_node = r.need(node, "name")
    name = r.text(name_node)
    if re.search(r"[\s()\";]", name):
        r.fail("E518", r.text_span(name_node), f"<obj> \"{name}\" cannot be used as a name in "
               "PDDL", "names have no spaces, brackets, quotes or `;`")
    geom = r.need(node, "geom")
    mesh = _resolve_mesh(r, opts, r.text(geom), r.text_span(geom), r.label(geom), mesh_bases)
    pose = r.pose(r.need(node, "pose"))
    mv = node.child("moveable")
    movable = r.boolean(mv) if mv is not None else False
    support = None
    if node.child("pssp") is not None:
        r.warn("W500", r.start_tag(node.child("pssp")), f"{r.label(node)}: <pssp> is not "
               "supported (ignored)", "give the support region as <sssp> xmin..zmax")
    sssp = node.child("sssp")
    if sssp is not None:
        v = {}
        for key in ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax"):
            v[key] = r.floats(r.need(sssp, key), (1,), f"<{key}>")[0]
        for a in "xyz":
            if v[a + "min"] > v[a + "max"]:
                r.fail("E511", r.text_span(sssp.child(a + "max")), f"{r.label(sssp)}: "
                       f"{a}max {fmt_num(v[a + 'max'])} is below {a}min {fmt_num(v[a + 'min'])}",
                       related=[Related(r.text_span(sssp.child(a + "min")), f"{a}min")])
        # Read in the object's frame: the table mesh spans x in [-0.8, 0.7], y in [-0.35, 0.35]
        # and the clutter files give xmin..xmax = -0.75..0.75 for rotated and unrotated tables.
        support = Box((v["xmin"], v["ymin"], v["zmin"]), (v["xmax"], v["ymax"], v["zmax"]))
    obj = SceneObject(name, pose, movable, Shape("mesh", mesh=mesh, convex=False), support, None,
                      r.origin(r.start_tag(node), node.path))
    return _Entry(obj, r.text_span(name_node))


def _planet_robot(r: _XmlReader, robots: XmlNode) -> tuple[RobotSpec, UrdfNames]:
    r.check_children(robots, ("robot",))
    all_robots = robots.all("robot")
    node = r.need(robots, "robot")
    if len(all_robots) > 1:
        r.warn("W506", r.start_tag(all_robots[1]), f"{robots.path}: more than one <robot>; only "
               "the first is used, as planet did")
    r.check_children(node, _PLANET_ROBOT_KNOWN)
    name_node = node.child("name")
    urdf_node = r.need(node, "urdf")
    path, names = _resolve_urdf(r, r.text(urdf_node), r.text_span(urdf_node), r.label(urdf_node))
    name = r.text(name_node) if name_node is not None else names.robot
    bp = node.child("basepose")
    pose = r.pose(bp) if bp is not None else Pose()
    mb = node.child("movebase")
    mobile = r.boolean(mb) if mb is not None else False
    joints: list[tuple[str, float]] = []
    torso = node.child("torso")
    if torso is not None:
        value = r.floats(torso, (1,), "<torso>")[0]
        if _known_joint(r, TORSO_JOINT, names, r.start_tag(torso), r.label(torso), warn=True):
            joints.append((TORSO_JOINT, value))
    controllable: tuple[str, ...] | None = None
    cj = node.child("controllable_joints")
    if cj is not None:
        controllable = _planet_joints(r, cj, names, joints)
    return RobotSpec(path, pose, mobile, tuple(joints), controllable, name,
                     r.origin(r.start_tag(node), node.path)), names


def _planet_joints(r: _XmlReader, cj: XmlNode, names: UrdfNames,
                   joints: list[tuple[str, float]]) -> tuple[str, ...]:
    r.check_children(cj, ("joint",))
    order: list[str] = []
    for j in cj.all("joint"):
        with r.part():
            jn = j.attrib.get("name")
            if not jn:
                r.fail("E505", r.start_tag(j), f"{j.path}: <joint> without a name attribute",
                       'write <joint name="...">initial value</joint>')
            if jn in order:
                r.fail("E510", r.start_tag(j), f"{j.path}: joint \"{jn}\" listed twice")
            _known_joint(r, jn, names, r.start_tag(j), r.label(cj), movable=True)
            value = r.floats(j, (1,), f"joint \"{jn}\"'s initial value")[0]
            order.append(jn)
            joints[:] = [(n, x) for n, x in joints if n != jn] + [(jn, value)]
    return tuple(order)


def _planet_bounds(r: _XmlReader, root: XmlNode, entries: list[_Entry],
                   robot: RobotSpec | None) -> tuple[tuple[float, float], ...]:
    wb = root.child("workspace_bounds")
    if wb is None:
        pts = [e.obj.pose.translation for e in entries]
        pts += [robot.base_pose.translation] if robot else []
        pts = pts or [(0.0, 0.0, 0.0)]
        margin = 2.0
        b = tuple((min(p[i] for p in pts) - margin, max(p[i] for p in pts) + margin)
                  for i in range(2)) + ((0.0, max(p[2] for p in pts) + margin),)
        r.warn("W505", Span(r.source.path, root.start, root.tag_end), "no <workspace_bounds>: "
               "using the objects' and robot's extent plus 2 m (" + ", ".join(
                   f"{a} {fmt_num(lo)}..{fmt_num(hi)}" for a, (lo, hi) in zip("xyz", b)) + ")",
               "add <workspace_bounds><x><low>..</low><high>..</high></x>...</workspace_bounds>")
        return b
    r.check_children(wb, ("x", "y", "z"))
    out = []
    for a in "xyz":
        axis = r.need(wb, a)
        lo_node, hi_node = r.need(axis, "low"), r.need(axis, "high")
        lo = r.floats(lo_node, (1,), "<low>")[0]
        hi = r.floats(hi_node, (1,), "<high>")[0]
        if lo > hi:
            r.fail("E511", r.text_span(hi_node), f"{axis.path}: high {fmt_num(hi)} is below low "
                   f"{fmt_num(lo)}", related=[Related(r.text_span(lo_node), "low")])
        out.append((lo, hi))
    return tuple(out)


# ============================================================================================
# Allowed-collision CSV (planet blacklist, tmit-star blocklist)


def load_allowed_pairs(path: str | Path, report: LoadReport | None = None
                       ) -> tuple[tuple[str, str], ...]:
    """``nameA,nameB`` per line (spaces trimmed; blank lines and ``#`` comments skipped).
    Returns the pairs in file order without repeats. A malformed line is SceneError E517."""
    source = read_source(path, "allowed-collision")
    report = report or LoadReport()
    r = Reader(source, report, legacy=False)
    out: list[tuple[str, str]] = []
    seen: set[tuple[str, str]] = set()
    offset = 0
    for lineno, line in enumerate(source.text.split("\n"), 1):
        start, offset = offset, offset + len(line) + 1
        body = line.strip()
        if not body or body.startswith("#"):
            continue
        fields = [f.strip() for f in body.split(",")]
        if len(fields) != 2 or not all(fields) or any(re.search(r"\s", f) for f in fields):
            lead = len(line) - len(line.lstrip())
            r.record("E516", Span(source.path, start + lead, start + len(line.rstrip())),
                     f"line {lineno}: expected two names separated by a comma, found "
                     f"\"{body}\"", "each line is nameA,nameB (link, joint or object names)")
            continue
        a, b = fields
        if (a, b) not in seen and (b, a) not in seen:
            seen.add((a, b))
            out.append((a, b))
    r.finish()
    return tuple(out)


# ============================================================================================
# Registry and entry point

SceneLoader = Callable[..., Scene]

#: format name -> loader(source, options, report, parsed=None). Names match ``Scene.format``.
SCENE_LOADERS: dict[str, SceneLoader] = {
    "tmpc-json": _load_native,
    "tmit-star-json": _load_tmit,
    "planet-xml": _load_planet,
}


def detect_scene_format(source: SourceFile, report: LoadReport | None = None
                        ) -> tuple[str, JsonDoc | XmlNode]:
    """Which loader reads ``source`` (and the parsed document, so it is parsed once)."""
    report = report or LoadReport()
    report.files[source.path] = source
    head = source.text.lstrip()
    if head.startswith("<") or source.path.lower().endswith(".xml"):
        return "planet-xml", parse_xml(source, report)
    doc = parse_json(source)
    v = doc.value
    name = display_name(source.path)
    if isinstance(v, dict) and "format" in v:
        f = v["format"]
        if isinstance(f, str) and f.startswith("tmpc-scene/") and f != NATIVE_SCENE_FORMAT:
            raise SceneError(error("E519", f"{name}: unknown scene format \"{f}\"",
                                   doc.span("/format"), f"this version of tmpc reads "
                                   f"\"{NATIVE_SCENE_FORMAT}\""), report.files)
        return "tmpc-json", doc
    if isinstance(v, dict) and _looks_tmit(v):
        return "tmit-star-json", doc
    raise SceneError(error(
        "E503", f"{name}: cannot tell which scene format this is", Span(source.path, doc.span("").start, doc.span("").start + 1),
        f"a native scene starts with \"format\": \"{NATIVE_SCENE_FORMAT}\" (docs/world.md); a "
        "tmit-star scene has robot.base_pose.rotation as a number or objects with is_static, "
        "obj_file or surface_bounds"), report.files)


def _looks_tmit(v: dict) -> bool:
    robot = v.get("robot")
    if isinstance(robot, dict):
        bp = robot.get("base_pose")
        if "joint_poses" in robot or (isinstance(bp, dict) and
                                      isinstance(bp.get("rotation"), (int, float))):
            return True
    objs = v.get("objects")
    return isinstance(objs, list) and any(
        isinstance(o, dict) and ({"is_static", "obj_file", "surface_bounds", "parent_name"} & set(o)
                                 or (isinstance(o.get("shape"), dict) and "extents" in o["shape"]))
        for o in objs)


def load_scene(path: str | Path, fmt: str | None = None, mesh_dir: str | Path | None = None, *,
               strict_meshes: bool = True, mesh_fallback_dirs: Iterable[str | Path] = (),
               report: LoadReport | None = None) -> Scene:
    """Read, check and convert a scene file. ``fmt``: a key of :data:`SCENE_LOADERS` (detected
    when None). ``mesh_dir``: planet's ``objdir``. Raises SceneError for any problem in the
    file or the files it names; warnings go to ``report``."""
    report = report if report is not None else LoadReport()
    opts = SceneOptions(Path(os.path.abspath(mesh_dir)) if mesh_dir else None, strict_meshes,
                        tuple(Path(os.path.abspath(d)) for d in mesh_fallback_dirs))
    source = read_source(path, "scene")
    report.files[source.path] = source
    if fmt is None:
        fmt, parsed = detect_scene_format(source, report)
        return SCENE_LOADERS[fmt](source, opts, report, parsed)
    if fmt not in SCENE_LOADERS:
        raise SceneError(error("E503", f"unknown scene format \"{fmt}\"", None, join_hints(
            did_you_mean(fmt, SCENE_LOADERS), "the formats are " + ", ".join(SCENE_LOADERS))))
    return SCENE_LOADERS[fmt](source, opts, report)
