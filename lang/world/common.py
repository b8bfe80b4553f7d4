"""Machinery shared by the scene loaders (:mod:`tmpc.lang.world.loaders`) and the run configurations
(:mod:`tmpc.lang.world.configs`): load reports and error collection, input files and the files a scene
refers to, rotations, URDF names, XML and JSON with positions, the checks across a whole scene
(names, parents, collision pairs) and the allowed-collision CSV."""

from __future__ import annotations

import difflib
import math
import os
import re
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Iterator, NoReturn

from tmpc.lang.diagnostics import Diagnostic, Related, SceneError, error, warning
from tmpc.lang.jsonpos import JsonDoc, parse_json, pointer
from tmpc.lang.source import SourceFile, Span
from tmpc.lang.world.robot import resolve_uri
from tmpc.lang.world.rotations import matrix_from_quat as matrix_from_quat
from tmpc.lang.world.rotations import orthonormality_error as orthonormality_error
from tmpc.lang.world.rotations import quat_from_matrix as quat_from_matrix
from tmpc.lang.world.scene import Box, Origin, Pose, Quat, RobotSpec, Scene, SceneObject, Vec3

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
# Rotations (the quaternion/matrix helpers live in tmpc.lang.world.rotations; re-exported here
# for the loaders that import them from this module)


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

