"""Reading plan files: a `tmpc-plan/1` object (docs/plan-format.md) or a bare planet/tmit-star
state array (LEGACY.md "Outputs") -> :class:`Plan`, a list of :class:`PlanState`.

This stage checks the *shape* of the file only (what a JSON schema would): every malformed value
is one error E800–E812 whose message names the JSON pointer (``/states/3/joints/x``) and whose
span points at the value in the file. Whether the values make sense for the world — joint names,
object names, limits, collisions, modes — is :mod:`tmpc.runtime.validate.core`'s job. The file is read
with :func:`json.loads` (fast for long plans); only when an error must be located is it parsed
again with positions.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

# (translation, quaternion xyzw) -> 4x4: numpy's one copy, re-exported by tmpc.runtime.plans
from tmpc.compiler.cache import robot_tree
from tmpc.compiler.rotations import pose_matrix
from tmpc.lang.diagnostics import InputError, error
from tmpc.lang.jsonpos import parse_json
from tmpc.lang.source import SourceFile, Span

FORMAT = "tmpc-plan/1"
STATE_FIELDS = ("joints", "base_pose", "object_poses", "action", "mode", "t")
#: a quaternion whose norm is further than this from 1 is malformed (E806)
QUAT_NORM_TOLERANCE = 1e-3


@dataclass(frozen=True)
class PlanState:
    """One state as the file gives it. ``joints``: name -> value; ``base``: world pose (4x4) of the
    robot's root frame, None when absent; ``objects``: object name (as written) -> world pose
    (4x4); ``action``: (name, args) or None; ``mode_atoms``: atoms as (predicate, args) tuples,
    None when the state has no ``mode``; ``mode_held``: object -> frame, None when absent."""

    index: int
    joints: dict[str, float]
    base: np.ndarray | None
    objects: dict[str, np.ndarray]
    action: tuple[str, tuple[str, ...]] | None = None
    action_text: str | None = None
    mode_atoms: tuple[tuple[str, tuple[str, ...]], ...] | None = None
    mode_held: dict[str, str] | None = None
    #: seconds from the plan's start (a timed plan, docs/plan-format.md); None when untimed
    t: float | None = None


@dataclass
class Plan:
    """``form``: ``tmpc-plan/1`` or ``array`` (a bare legacy state array, modes reconstructed by
    simulation). ``actions``: the top-level action list of a tmpc plan (None if absent)."""

    path: str
    form: str
    states: list[PlanState]
    status: str | None = None
    actions: list[str] | None = None
    meta: dict = field(default_factory=dict)

    @property
    def timed(self) -> bool:
        """Every state has a time (``tmpc time``, ``tmpc run --timed``)."""
        return all(s.t is not None for s in self.states)

    @property
    def action_count(self) -> int:
        return sum(1 for s in self.states if s.action is not None)


class PlanError(InputError):
    """A plan file that cannot be read or does not have the shape of a plan (E800–E812)."""


# ---------------------------------------------------------------------------------------------
# reading


def check_plan_fits(world, plan: Plan, input_path) -> None:
    """A plan made for another problem is said so first (E817), not as a list of violations or
    a drawing of the wrong robot: it names joints the robot does not have or objects the scene
    does not. (A plan whose input file merely changed is only noted by ``validate``.)"""
    if plan.form != "tmpc-plan/1":
        return
    scene = world.scene
    objects = {o.name.lower() for o in scene.objects}
    joints: set[str] | None = None
    if scene.robot is not None:
        tree = robot_tree(scene.robot.urdf, Path(scene.path).parent, strict_meshes=False)
        joints = {j.name for j in tree.joints}
    odd_objects = sorted({n for st in plan.states for n in st.objects if n.lower() not in objects})
    odd_joints = sorted({n for st in plan.states for n in st.joints
                         if joints is not None and n not in joints})
    if not odd_objects and not odd_joints:
        return
    made_for = plan.meta.get("input") if isinstance(plan.meta.get("input"), dict) else {}
    parts = ([f"joints {', '.join(odd_joints[:4])}"] if odd_joints else []) + \
        ([f"objects {', '.join(odd_objects[:4])}"] if odd_objects else [])
    raise InputError(error(
        "E817", f"{plan.path} was made for another problem"
        + (f" ({made_for.get('path')})" if made_for.get("path") else "")
        + f": it names {' and '.join(parts)}, which {input_path} does not have", None,
        "give the run configuration or artifact the plan was made for"))


def read_plan(path: str | Path) -> Plan:
    """Read and shape-check a plan file. Raises :class:`PlanError`."""
    path = str(path)
    try:
        src = SourceFile.read(path)
    except (OSError, UnicodeDecodeError) as exc:
        why = getattr(exc, "strerror", None) or str(exc)
        raise PlanError(error("E800", f"cannot read the plan file {path}: {why}", None)) from None
    return parse_plan(src)


def parse_plan(src: SourceFile) -> Plan:
    try:
        data = json.loads(src.text)
    except json.JSONDecodeError as exc:
        span = Span(src.path, exc.pos, min(exc.pos + 1, len(src.text)))
        raise PlanError(error("E800", f"{_short(src.path)}: not valid JSON: {exc.msg}", span,
                              "a plan file is one JSON object (tmpc-plan/1) or a JSON array of "
                              "states"), {src.path: src}) from None
    return _Reader(src).plan(data)


def _array_convention(data: list) -> str:
    """Which planner wrote a bare state array, from how it spells actions: planet ``[name,
    args...]``, tmit-star ``"name(arg, arg)"``; ``array`` when it has none or spells them
    ``"(name arg ...)"``."""
    for s in data:
        a = s.get("action") if isinstance(s, dict) else None
        if isinstance(a, list):
            return "planet"
        if isinstance(a, str) and not a.lstrip().startswith("("):
            return "tmit-star"
    return "array"


def _short(path: str) -> str:
    return path.replace("\\", "/").rsplit("/", 1)[-1] or path


class _Reader:
    def __init__(self, src: SourceFile):
        self.src = src
        self._doc = None

    def fail(self, code: str, pointer: str, message: str, hint: str | None = None) -> PlanError:
        """An error at the value ``pointer`` points at (its span: the file parsed again with
        positions)."""
        span = None
        try:
            if self._doc is None:
                self._doc = parse_json(self.src)
            span = self._doc.span(pointer)
        except Exception:   # positions are a courtesy; json.loads accepted the file
            span = None
        where = pointer or "/"
        return PlanError(error(code, f"{_short(self.src.path)}: {where}: {message}", span, hint),
                         {self.src.path: self.src})

    # ---- top level -------------------------------------------------------------------------
    def plan(self, data) -> Plan:
        if isinstance(data, list):
            states = self.states(data, "")
            return Plan(self.src.path, "array", states,
                        meta={"convention": _array_convention(data)})
        if not isinstance(data, dict):
            raise self.fail("E801", "", f"expected a JSON object or an array of states, found "
                            f"{_kind(data)}", "see docs/plan-format.md")
        fmt = data.get("format")
        if fmt != FORMAT:
            if fmt is None and "states" not in data:
                raise self.fail("E801", "", "not a plan: no `format` and no `states`",
                                "a tmpc plan has \"format\": \"tmpc-plan/1\" and \"states\"")
            if fmt is not None:
                raise self.fail("E802", "/format", f"unsupported plan format {fmt!r}",
                                f"this tmpc reads \"{FORMAT}\"")
        if "states" not in data:
            raise self.fail("E803", "", "the plan has no `states`")
        status = data.get("status")
        if status is not None and not isinstance(status, str):
            raise self.fail("E811", "/status", f"expected a string, found {_kind(status)}",
                            "`solved` or `partial`")
        actions = data.get("actions")
        if actions is not None and not (isinstance(actions, list) and
                                        all(isinstance(a, str) for a in actions)):
            raise self.fail("E811", "/actions", "expected a list of ground actions as strings",
                            "e.g. [\"(pickup stick1 table1 gripper)\"]")
        states = self.states(data["states"], "/states")
        meta = {k: v for k, v in data.items() if k not in ("states", "actions", "status")}
        return Plan(self.src.path, FORMAT, states, status, actions, meta)

    def states(self, value, ptr: str) -> list[PlanState]:
        if not isinstance(value, list):
            raise self.fail("E803", ptr, f"expected a list of states, found {_kind(value)}")
        if not value:
            raise self.fail("E803", ptr, "the plan has no states",
                            "the first state is the problem's initial state")
        states = [self.state(s, f"{ptr}/{i}", i) for i, s in enumerate(value)]
        for i in range(1, len(states)):
            a, b = states[i - 1].t, states[i].t
            if a is not None and b is not None and b < a:
                raise self.fail("E818", f"{ptr}/{i}/t", f"time {b:g} is before the previous "
                                f"state's {a:g}", "a timed plan's times never decrease")
        return states

    # ---- one state -------------------------------------------------------------------------
    def state(self, s, ptr: str, index: int) -> PlanState:
        if not isinstance(s, dict):
            raise self.fail("E804", ptr, f"a state is a JSON object, found {_kind(s)}")
        unknown = sorted(set(s) - set(STATE_FIELDS))
        if unknown:
            raise self.fail("E804", f"{ptr}/{unknown[0]}", f"unknown state field(s) {unknown}",
                            "fields are " + ", ".join(STATE_FIELDS))
        joints = self.joints(s.get("joints", {}), f"{ptr}/joints")
        base = None if s.get("base_pose") is None else self.pose(s["base_pose"],
                                                                 f"{ptr}/base_pose")
        objects = self.objects(s.get("object_poses", {}), f"{ptr}/object_poses")
        action = self.action(s.get("action"), f"{ptr}/action")
        atoms, held = self.mode(s.get("mode"), f"{ptr}/mode")
        text = None if action is None else "(" + " ".join((action[0],) + action[1]) + ")"
        t = s.get("t")
        if t is not None and not (_number(t) and t >= 0):
            raise self.fail("E818", f"{ptr}/t", f"a state's time is a finite number >= 0 "
                            f"(seconds from the plan's start), found {_show(t)}")
        return PlanState(index, joints, base, objects, action, text, atoms, held,
                         None if t is None else float(t))

    def joints(self, value, ptr: str) -> dict[str, float]:
        if value is None:
            return {}
        if not isinstance(value, dict):
            raise self.fail("E805", ptr, f"expected an object {{joint: value}}, found "
                            f"{_kind(value)}")
        out = {}
        for name, v in value.items():
            if not _number(v):
                raise self.fail("E805", f"{ptr}/{name}", f"a joint value is a finite number, "
                                f"found {_show(v)}")
            out[name] = float(v)
        return out

    def objects(self, value, ptr: str) -> dict[str, np.ndarray]:
        if value is None:
            return {}
        if not isinstance(value, dict):
            raise self.fail("E807", ptr, f"expected an object {{object: pose}}, found "
                            f"{_kind(value)}")
        return {name: self.pose(v, f"{ptr}/{name}") for name, v in value.items()}

    def pose(self, value, ptr: str) -> np.ndarray:
        if not isinstance(value, dict):
            raise self.fail("E806", ptr, "a pose is {\"translation\": [x, y, z], \"rotation\": "
                            "[x, y, z, w]}, found " + _kind(value))
        extra = sorted(set(value) - {"translation", "rotation"})
        if extra:
            raise self.fail("E806", f"{ptr}/{extra[0]}", f"unknown pose field(s) {extra}",
                            "a pose has `translation` and `rotation` (quaternion x, y, z, w)")
        t = self.vector(value.get("translation", [0.0, 0.0, 0.0]), 3, f"{ptr}/translation")
        r = self.vector(value.get("rotation", [0.0, 0.0, 0.0, 1.0]), 4, f"{ptr}/rotation")
        norm = math.sqrt(sum(x * x for x in r))
        if abs(norm - 1.0) > QUAT_NORM_TOLERANCE:
            raise self.fail("E806", f"{ptr}/rotation", f"the quaternion has norm {norm:.6g}, "
                            "not 1", "rotations are unit quaternions [x, y, z, w]")
        return pose_matrix(t, [x / norm for x in r])

    def vector(self, value, n: int, ptr: str) -> list[float]:
        if not (isinstance(value, list) and len(value) == n and all(_number(x) for x in value)):
            raise self.fail("E806", ptr, f"expected {n} finite numbers, found {_show(value)}")
        return [float(x) for x in value]

    def action(self, value, ptr: str) -> tuple[str, tuple[str, ...]] | None:
        if value is None:
            return None
        if isinstance(value, list):      # planet: [name, args...]
            if not value or not all(isinstance(x, str) and x.strip() for x in value):
                raise self.fail("E808", ptr, "a planet action is a non-empty list of names "
                                "[name, arg, ...]")
            return value[0].strip(), tuple(x.strip() for x in value[1:])
        if isinstance(value, str):
            parsed = parse_ground(value)
            if parsed is None:
                raise self.fail("E808", ptr, f"cannot read the action {value!r}",
                                "write a ground action as \"(name arg ...)\"")
            return parsed
        raise self.fail("E808", ptr, f"an action is a string \"(name arg ...)\", a list [name, "
                        f"arg, ...] or null, found {_kind(value)}")

    def mode(self, value, ptr: str):
        if value is None:
            return None, None
        if not isinstance(value, dict):
            raise self.fail("E809", ptr, "a mode is {\"atoms\": [...], \"held\": {object: "
                            "frame}}, found " + _kind(value))
        extra = sorted(set(value) - {"atoms", "held"})
        if extra:
            raise self.fail("E809", f"{ptr}/{extra[0]}", f"unknown mode field(s) {extra}",
                            "a mode has `atoms` and `held`")
        atoms = value.get("atoms", [])
        if not isinstance(atoms, list):
            raise self.fail("E809", f"{ptr}/atoms", f"expected a list of atoms, found "
                            f"{_kind(atoms)}")
        parsed = []
        for i, a in enumerate(atoms):
            p = parse_ground(a) if isinstance(a, str) else None
            if p is None:
                raise self.fail("E810", f"{ptr}/atoms/{i}", f"cannot read the atom {a!r}",
                                "write an atom as \"(predicate arg ...)\"")
            parsed.append(p)
        held = value.get("held", {})
        if held is None:
            held = {}
        if not (isinstance(held, dict) and all(isinstance(v, str) for v in held.values())):
            raise self.fail("E809", f"{ptr}/held", "expected an object {object: robot frame}")
        return tuple(parsed), dict(held)


_NAME = r"[^\s()\[\],\"']+"
_SEXPR = re.compile(rf"^\(\s*({_NAME})((?:\s+{_NAME})*)\s*\)$")
_CALL = re.compile(rf"^({_NAME})\s*\(\s*((?:{_NAME}(?:\s*,\s*|\s+)?)*)\)$")
_BARE = re.compile(rf"^({_NAME})((?:\s+{_NAME})*)$")


def parse_ground(text: str) -> tuple[str, tuple[str, ...]] | None:
    """``"(pickup a b)"``, ``"pickup a b"`` or ``"pickup(a, b)"`` -> ``("pickup", ("a", "b"))``;
    None if it is none of these."""
    t = text.strip()
    for rx in (_SEXPR, _CALL, _BARE):
        m = rx.match(t)
        if m:
            return m.group(1), tuple(x for x in re.split(r"[\s,]+", m.group(2)) if x)
    return None


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _kind(v) -> str:
    return {dict: "an object", list: "an array", str: "a string", bool: "a boolean",
            type(None): "null"}.get(type(v), "a number")


def _show(v) -> str:
    text = json.dumps(v)
    return text if len(text) <= 40 else text[:37] + "..."
