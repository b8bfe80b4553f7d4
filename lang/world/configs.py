"""Run configurations: native manifest TOML, planet run TOML, tmit-star problem spec -> RunConfig.

:data:`CONFIG_LOADERS` maps a format name (the value of ``RunConfig.format``) to its loader;
:func:`load_config` detects the format and returns a :class:`~tmpc.lang.world.scene.RunConfig` whose
paths are absolute and exist (``output`` need not). Problems are
:class:`~tmpc.lang.diagnostics.SceneError` diagnostics pointing at the key's line; keys the legacy
tools did not read (``max_iterations``, ``perf_file``) are accepted, unknown legacy keys are
warnings (W500), unknown native keys are errors (E504). See docs/world.md.

Relative paths: native manifest -> the manifest's directory; legacy -> the config's directory or
any of its ancestors, the first that exists (planet and tmit-star ran from their repo roots).
"""

from __future__ import annotations

import math
import os
import re
import tomllib
from dataclasses import replace
from pathlib import Path
from typing import Any, Callable, Iterable, NoReturn

from tmpc.lang.diagnostics import Related, SceneError, error
from tmpc.lang.fileio import unwritable
from tmpc.lang.jsonpos import parse_json
from tmpc.lang.source import SourceFile, Span
from tmpc.lang.world.loaders import (
    JsonReader,
    LoadReport,
    Reader,
    did_you_mean,
    display_name,
    find_file,
    join_hints,
    load_scene,
    read_source,
    search_dirs,
    tried_text,
)
from tmpc.lang.world.scene import LEGACY_TOLERANCES, RunConfig, Scene

__all__ = ["CONFIG_LOADERS", "PARAM_CHOICES", "PLANNER_PARAMS", "PLANET_PARAMS",
           "detect_config_format", "load_config", "load_config_scene", "load_planet_params",
           "rename_scene"]

#: planner parameters a native manifest may set under [planner]: name -> (type, meaning).
#: Planners read the ones they use; planet's come from its params TOML, tmit-star's from the spec.
PLANNER_PARAMS: dict[str, tuple[type, str]] = {
    "coin_bias": (float, "probability of a heuristic (vs uniform) sample (planet: 0.3)"),
    "gd_tries": (int, "projection attempts per sample (planet: 3)"),
    "max_samples": (int, "samples per sampler call (planet: 10)"),
    "success_scale": (float, "weight of past successes in transition priority (planet: 100)"),
    "goal_weight": (float, "priority weight of the goal entry (planet: 4)"),
    "min_steps": (int, "shortest task plan tried (tmit-star: 0)"),
    "max_steps": (int, "longest task plan tried (tmit-star: 100)"),
    "batch_size": (int, "samples per mode per batch (tmit-star: 50)"),
    "batch_budget": (int, "batches before a new task plan (tmit-star: 5)"),
    "projection_iterations": (int, "projector steps per transition attempt of the optimal "
                                   "planner (default 30)"),
    "confirm_resolution": (float, "motion-check resolution at which the optimal planner "
                                  "confirms a path found (default 0.05, the resolution)"),
    "task_planner": (str, "the optimal and decoupled planners' task planner to a first "
                          "solution: auto, sat or greedy (default auto: docs/planning.md)"),
    "task_weight": (float, "the optimal planner's greedy task plans shortened by weighted A* "
                           "with this weight (default 2; 0: off; docs/planning.md)"),
    "lazy_motions": (bool, "the decoupled planner plans a task plan's motions once its "
                           "transitions all hold (default false; docs/planning.md)"),
    "lookahead": (bool, "the decoupled planner tries first the transition configurations "
                        "after which the plan's next step on the object grasped or put down "
                        "holds (default false; docs/planning.md)"),
    "backjump": (bool, "the decoupled planner goes back from a step it cannot take to the "
                       "latest step that moved what the step depends on (default false; "
                       "docs/planning.md)"),
    "park_idle": (bool, "the decoupled planner puts the arm a step does not use back where "
                        "the run started it (default false; docs/planning.md)"),
    "motion_checks": (int, "tmpc's checks the decoupled planner's OMPL planner gets per "
                           "motion (default 4000; `tmpc run --motion-checks` overrides it; "
                           "docs/planning.md)"),
    "motion_budget": (float, "seconds per motion: tmpc's lazy PRM's budget (default 2) and a "
                             "wall-clock ceiling on OMPL's planners besides `motion_checks` "
                             "(default none; `tmpc run --motion-budget` overrides it; "
                             "docs/planning.md)"),
    "motion_range": (float, "the longest edge (Euclidean over the configuration's "
                            "coordinates) OMPL's motion planner grows its trees by in the "
                            "decoupled planner (default 0: OMPL's own, a fifth of the space's "
                            "extent; docs/planning.md)"),
    "seed_starts": (int, "of the decoupled planner's 16 projection starts a round after a "
                         "step's first, this many are earlier valid transition configurations "
                         "of the same arm (default 0; 0-8; docs/planning.md)"),
    "retreat_sideways": (bool, "the decoupled planner's motions retreat with the hand the "
                               "action at their end grasps or releases with, sideways too "
                               "(default false; docs/planning.md)"),
    "park_first": (bool, "with park_idle, the decoupled planner moves the arm a step does "
                         "not use to where the run started it first, alone, then the rest "
                         "(default false; docs/planning.md)"),
    "spread_placements": (bool, "the decoupled planner tries a release's configurations "
                                "where the object has the most room beside it first, and more "
                                "aimed that way (default false; docs/planning.md)"),
    "aim_placements": (bool, "with spread_placements, the decoupled planner projects a "
                             "release's configurations from starts aimed the way the room "
                             "grows too (default true; docs/planning.md)"),
    "give_up_missed": (bool, "with backjump, the decoupled planner ends a task plan at a step "
                             "out of the arm's reach whatever the steps before it did "
                             "(default false; docs/planning.md)"),
    "probe_reach": (bool, "the decoupled planner, after a grasp out of reach, probes the same "
                          "grasp of every object not moved yet where it stands (default "
                          "false; docs/planning.md)"),
    "chain_retry": (float, "with lazy_motions, a failed motion of the decoupled planner's "
                           "chain whose transitions all hold is planned once more on this "
                           "multiple of the motion budget (default 1: off; docs/planning.md)"),
    "lua_instructions": (int, "Lua VM instructions one predicate call may run (default "
                              "10,000,000)"),
    "lua_seconds": (float, "CPU seconds one Lua predicate call may take (default 10)"),
    "lua_memory": (int, "bytes a Lua predicate file may allocate (default 64 MiB)"),
    "collision_tolerance": (float, "penetration depth (m) not counted as a collision (planet: "
                                   f"{LEGACY_TOLERANCES['planet-toml']}, tmit-star: "
                                   f"{LEGACY_TOLERANCES['tmit-star-json']})"),
}
#: keys of planet's params TOML (its defaults are in PLANNER_PARAMS)
PLANET_PARAMS = ("coin_bias", "gd_tries", "max_samples", "success_scale", "goal_weight")


# --------------------------------------------------------------------------------------------
# TOML with key positions (tomllib keeps none; simple line scanning is enough for configs)

_KEY_LINE = re.compile(r"""\s*("(?:[^"\\]|\\.)*"|'[^']*'|[A-Za-z0-9_.-]+)\s*=\s*""")
_HEADER = re.compile(r"\s*\[\s*([^\[\]]+?)\s*\]\s*(?:#.*)?$")


def toml_positions(source: SourceFile) -> tuple[dict[str, Span], dict[str, Span]]:
    """(value spans, key spans) by dotted key (``planner.coin_bias``); table headers are in the
    key spans under the table's name. First line of a multi-line value only."""
    values: dict[str, Span] = {}
    keys: dict[str, Span] = {}
    table, offset = "", 0
    for line in source.text.split("\n"):
        start, offset = offset, offset + len(line) + 1
        h = _HEADER.match(line)
        if h and not line.lstrip().startswith("[["):
            table = h.group(1).replace(" ", "")
            keys.setdefault(table, Span(source.path, start + line.index("["),
                                        start + len(line.rstrip())))
            continue
        m = _KEY_LINE.match(line)
        if not m or line.lstrip().startswith("#"):
            continue
        key = m.group(1).strip("\"'")
        full = f"{table}.{key}" if table else key
        ks = start + m.start(1)
        keys.setdefault(full, Span(source.path, ks, start + m.end(1)))
        vs, ve = start + m.end(), start + len(_strip_comment(line).rstrip())
        values.setdefault(full, Span(source.path, vs, max(ve, vs + 1)))
    return values, keys


def _strip_comment(line: str) -> str:
    quote = None
    for i, ch in enumerate(line):
        if quote:
            if ch == quote:
                quote = None
        elif ch in "\"'":
            quote = ch
        elif ch == "#":
            return line[:i]
    return line


class TomlReader(Reader):
    """Typed access to a TOML document; errors point at the key's value (or its table)."""

    def __init__(self, source: SourceFile, report: LoadReport, legacy: bool):
        super().__init__(source, report, legacy)
        self.data = self._parse()
        self.values, self.keys = toml_positions(source)

    def _parse(self) -> dict[str, Any]:
        try:
            return tomllib.loads(self.source.text)
        except tomllib.TOMLDecodeError as exc:
            msg = str(exc)
            m = re.search(r"\(at line (\d+), column (\d+)\)", msg)
            pos = self.source.offset(int(m.group(1)), int(m.group(2))) if m \
                else len(self.source.text)
            what = re.sub(r"\s*\(at [^)]*\)$", "", msg)
            raise SceneError(error(
                "E502", f"{self.name}: malformed TOML: {what}",
                Span(self.source.path, pos, pos + 1),
                'a line is key = value; strings need quotes: scene = "scene.json"'),
                self.report.files) from None

    def span(self, key: str) -> Span:
        if key in self.values:
            return self.values[key]
        table = key.rsplit(".", 1)[0] if "." in key else ""
        return self.keys.get(table) or Span(self.source.path, 0, 1)

    def key_span(self, key: str) -> Span:
        return self.keys.get(key) or self.span(key)

    def table(self, name: str, value: Any) -> dict:
        if not isinstance(value, dict):
            self.fail("E506", self.span(name), f"[{name}] must be a table, found "
                      f"{type(value).__name__}", f"write it as a [{name}] section")
        return value

    def check_keys(self, prefix: str, data: dict, required: Iterable[str],
                   optional: Iterable[str]) -> None:
        required, optional = tuple(required), tuple(optional)
        known = required + optional
        where = f"[{prefix}]" if prefix else "the top level"
        for key in data:
            if key in known:
                continue
            full = f"{prefix}.{key}" if prefix else key
            hint = join_hints(did_you_mean(key, known), "known keys: " + ", ".join(known))
            if self.legacy:
                self.warn("W500", self.key_span(full), f"{where}: unknown key \"{key}\" (ignored)",
                          hint)
            else:
                self.record("E504", self.key_span(full), f"{where}: unknown key \"{key}\"", hint)
        for key in required:
            if key not in data:
                self.record("E505", self.span(f"{prefix}.{key}" if prefix else key),
                            f"{where}: missing \"{key}\"", f"add {key} = \"...\"")

    def expect(self, key: str, value: Any, typ: type) -> Any:
        ok = isinstance(value, typ) and not isinstance(value, bool) if typ is not bool \
            else isinstance(value, bool)
        if typ is float and isinstance(value, int) and not isinstance(value, bool):
            return float(value)
        if not ok:
            names = {str: "a string", float: "a number", int: "a whole number",
                     bool: "true or false"}
            self.fail("E506", self.span(key), f"{key}: expected {names[typ]}, found "
                      f"{type(value).__name__} {value!r}")
        return value


# --------------------------------------------------------------------------------------------
# Paths


def _path(r: Reader, span: Span, key: str, raw: Any, legacy: bool, what: str,
          want_dir: bool = False) -> Path:
    """An input file (or directory) named in a config: must exist."""
    if not isinstance(raw, str) or not raw.strip():
        r.fail("E506", span, f"{key}: expected a path string, found {raw!r}")
    found, tried = find_file(raw, search_dirs(r.directory, legacy), want_dir=want_dir)
    if found is None:
        r.fail("E515", span, f"{key}: {what} \"{raw}\" not found", join_hints(
            tried_text(tried), "relative paths are relative to this file's directory"
            + (" or one of its parents" if legacy else "")))
    return found


def _output(r: Reader, span: Span, key: str, raw: Any) -> Path:
    if not isinstance(raw, str) or not raw.strip():
        r.fail("E506", span, f"{key}: expected a path string, found {raw!r}")
    out = Path(os.path.normpath(r.directory / os.path.expanduser(raw)))
    why = unwritable(out)
    if why:       # `tmpc run` refuses it before planning (E828); other commands do not write it
        r.warn("W507", span, f"{key}: `tmpc run` cannot write the plan to {out}: {why}",
               "create the folder, or give `tmpc run -o` another path")
    return out


def _finish(r: Reader, build: Callable[[], RunConfig]) -> RunConfig:
    cfg = None
    with r.part():
        cfg = build()
    r.finish()
    assert cfg is not None
    return cfg


# --------------------------------------------------------------------------------------------
# Native manifest TOML

_PROBLEM_KEYS = (("domain", "problem", "scene"),
                 ("semantics", "allowed_collisions", "mesh_dir"))


def _load_native(source: SourceFile, report: LoadReport) -> RunConfig:
    r = TomlReader(source, report, legacy=False)
    return _finish(r, lambda: _native(r))


def _native(r: TomlReader) -> RunConfig:
    data = r.data
    r.check_keys("", data, ("problem",), ("planner", "names", "robot"))
    prob = r.table("problem", data.get("problem"))
    r.check_keys("problem", prob, *_PROBLEM_KEYS)
    r.finish()
    paths: dict[str, Path] = {}
    what = {"domain": "PDDL domain", "problem": "PDDL problem", "scene": "scene file",
            "semantics": "semantics module (.tmpc) or Lua predicate file",
            "allowed_collisions": "allowed-collision CSV", "mesh_dir": "mesh directory"}
    for key in (*_PROBLEM_KEYS[0], *_PROBLEM_KEYS[1]):
        if key in prob:
            with r.part():
                paths[key] = _path(r, r.span(f"problem.{key}"), f"problem.{key}", prob[key],
                                   False, what[key], want_dir=key == "mesh_dir")
    planner = r.table("planner", data.get("planner", {}))
    r.check_keys("planner", planner, (), ("name", "time_limit", "output", *PLANNER_PARAMS))
    params: list[tuple[str, object]] = []
    time_limit = output = name = None
    for key, value in planner.items():
        with r.part():
            full = f"planner.{key}"
            if key == "name":
                name = r.expect(full, value, str)
            elif key == "time_limit":
                time_limit = _positive(r, full, r.expect(full, value, float))
            elif key == "output":
                output = _output(r, r.span(full), full, value)
            elif key in PLANNER_PARAMS:
                params.append((key, _param(r, full, value, PLANNER_PARAMS[key][0])))
    names = _names(r, data.get("names", {}))
    robot = r.table("robot", data.get("robot", {}))
    r.check_keys("robot", robot, (), ("mobile_base",))
    mobile = None
    if "mobile_base" in robot:
        with r.part():
            mobile = r.expect("robot.mobile_base", robot["mobile_base"], bool)
    r.finish()
    # `semantics` names a native semantics module (.tmpc) or a legacy Lua predicate file
    semantics = paths.get("semantics")
    module = semantics if semantics is not None and semantics.suffix.lower() == ".tmpc" else None
    return RunConfig(r.source.path, paths["domain"], paths["problem"], paths["scene"],
                     None if module else semantics, paths.get("allowed_collisions"),
                     paths.get("mesh_dir"), tuple(params), time_limit, output, "tmpc-toml",
                     names=names, module=module, mobile_base=mobile, planner=name)


def _names(r: TomlReader, value: Any) -> tuple[tuple[str, str], ...]:
    """``[names]``: ``pddl_name = "scene_name"`` pairs. Each value a string naming a PDDL-writable
    name (E506, E518); one scene object given two PDDL names, or two PDDL names equal but for
    case, is E525. Whether the scene has the names is checked when it is loaded
    (:func:`load_config_scene`)."""
    table = r.table("names", value)
    out: list[tuple[str, str]] = []
    seen_pddl: dict[str, str] = {}
    seen_scene: dict[str, str] = {}
    for pddl, scene_name in table.items():
        key = f"names.{pddl}"
        with r.part():
            scene_name = r.expect(key, scene_name, str)
            if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_\-]*", pddl):
                r.fail("E518", r.key_span(key), f"[names]: \"{pddl}\" cannot be used as a name "
                       "in PDDL", "a PDDL name starts with a letter and has letters, digits, "
                       "`-` and `_`")
            if pddl.lower() in seen_pddl:
                r.fail("E525", r.key_span(key), f"[names]: \"{pddl}\" and "
                       f"\"{seen_pddl[pddl.lower()]}\" are one PDDL name (PDDL ignores case)",
                       related=[Related(r.key_span(f"names.{seen_pddl[pddl.lower()]}"),
                                        "first given here")])
            if scene_name.lower() in seen_scene:
                first = seen_scene[scene_name.lower()]
                r.fail("E525", r.span(key), f"[names]: scene object \"{scene_name}\" is given two "
                       f"PDDL names, \"{first}\" and \"{pddl}\"", "one name per object",
                       related=[Related(r.span(f"names.{first}"), "first named here")])
            seen_pddl[pddl.lower()] = pddl
            seen_scene[scene_name.lower()] = pddl
            out.append((pddl, scene_name))
    return tuple(out)


def load_config_scene(config: RunConfig, report: LoadReport | None = None,
                      **options: Any) -> Scene:
    """The scene of a run configuration as its run sees it: loaded with the configuration's
    mesh directory (``options`` go to :func:`~tmpc.lang.world.loaders.load_scene`), its objects
    renamed by the manifest's ``[names]`` (attachments, parents and allowed-collision pairs
    too). A scene name the scene lacks is E524 (with a "did you mean"); a PDDL name that another
    scene object keeps is E525; both at the ``[names]`` entry."""
    report = report if report is not None else LoadReport()
    scene = load_scene(config.scene, mesh_dir=config.mesh_dir, report=report, **options)
    if config.mobile_base is not None and scene.robot is not None:
        scene = replace(scene, robot=replace(scene.robot, mobile_base=config.mobile_base))
    if not config.names:
        return scene
    return rename_scene(scene, config, report)


def rename_scene(scene: Scene, config: RunConfig, report: LoadReport) -> Scene:
    """``scene`` with each object named by ``config.names`` called by its PDDL name."""
    source = read_source(config.path, "configuration")
    report.files[source.path] = source
    values, _ = toml_positions(source)
    errors = []
    names = {o.name.lower(): o.name for o in scene.objects}
    new: dict[str, str] = {}                  # scene name (lower) -> PDDL name
    for pddl, scene_name in config.names:
        span = values.get(f"names.{pddl}")
        if scene_name.lower() not in names:
            errors.append(error("E524", f"{display_name(config.path)}: [names] {pddl}: the scene "
                                f"({display_name(scene.path)}) has no object \"{scene_name}\"",
                                span, join_hints(did_you_mean(scene_name, names.values()),
                                                 "the values are the scene's object names")))
        else:
            new[scene_name.lower()] = pddl
    final = {k: new.get(k, v) for k, v in names.items()}
    for pddl, scene_name in config.names:
        if scene_name.lower() not in new:
            continue
        other = [v for k, v in names.items() if k != scene_name.lower()
                 and final[k].lower() == pddl.lower()]
        if other:
            errors.append(error("E525", f"{display_name(config.path)}: [names] {pddl}: scene "
                                f"object \"{other[0]}\" is called \"{pddl}\" too",
                                values.get(f"names.{pddl}"), f"give \"{other[0]}\" another PDDL "
                                "name in [names], or choose another name"))
    if errors:
        raise SceneError(errors, report.files)

    def to(n: str | None) -> str | None:
        return None if n is None else new.get(n.lower(), n)

    objects = tuple(replace(o, name=to(o.name), parent=to(o.parent),
                            attachments=tuple(to(a) for a in o.attachments))
                    for o in scene.objects)
    pairs = tuple((to(a), to(b)) for a, b in scene.allowed_collisions)
    return replace(scene, objects=objects, allowed_collisions=pairs)


def _positive(r: Reader, key: str, x: float) -> float:
    if not (x > 0 and math.isfinite(x)):
        r.fail("E512", r.span(key),  # type: ignore[attr-defined]
               f"{key}: must be a positive finite number, found {x:g}")
    return x


#: parameters with an upper bound (probabilities)
_AT_MOST = {"coin_bias": 1.0}


#: parameters that name one of a few choices (the planners check the same tuples)
PARAM_CHOICES = {"task_planner": ("auto", "sat", "greedy")}


def _param(r: TomlReader, key: str, value: Any, typ: type) -> object:
    v = r.expect(key, value, typ)
    name = key.rpartition(".")[2]
    if typ is str:
        if v not in PARAM_CHOICES.get(name, (v,)):
            r.fail("E512", r.span(key), f"{key}: must be one of "
                   f"{', '.join(PARAM_CHOICES[name])}, found {v!r}")
        return v
    high = _AT_MOST.get(name)
    if not math.isfinite(v) or v < 0 or (high is not None and v > high):
        want = f"between 0 and {high:g}" if high is not None else "a finite number >= 0"
        r.fail("E512", r.span(key), f"{key}: must be {want}, found {v}")
    return v


# --------------------------------------------------------------------------------------------
# planet run TOML (FACTS 3.1, 3.2)

_PLANET_REQUIRED = ("domain", "problem", "scene")
_PLANET_OPTIONAL = ("objdir", "semantics", "output", "perf_file", "params", "blacklist", "timeout")


def _load_planet(source: SourceFile, report: LoadReport) -> RunConfig:
    r = TomlReader(source, report, legacy=True)
    return _finish(r, lambda: _planet(r))


def _planet(r: TomlReader) -> RunConfig:
    data = r.data
    r.check_keys("", data, _PLANET_REQUIRED, _PLANET_OPTIONAL)
    r.finish()
    what = {"domain": "PDDL domain", "problem": "PDDL problem", "scene": "scene file",
            "semantics": "Lua predicate file", "blacklist": "collision blacklist CSV",
            "objdir": "mesh directory (objdir)", "params": "params file"}
    paths: dict[str, Path] = {}
    for key in what:
        if key in data:
            with r.part():
                paths[key] = _path(r, r.span(key), key, data[key], True, what[key],
                                   want_dir=key == "objdir")
    time_limit = output = None
    with r.part():
        if "timeout" in data:
            time_limit = _positive(r, "timeout", r.expect("timeout", data["timeout"], float))
        if "output" in data:
            output = _output(r, r.span("output"), "output", data["output"])
        if "perf_file" in data:        # planet appended timings here; tmpc reports its own
            r.expect("perf_file", data["perf_file"], str)
    r.finish()
    params = load_planet_params(paths["params"], r.report) if "params" in paths else ()
    return RunConfig(r.source.path, paths["domain"], paths["problem"], paths["scene"],
                     paths.get("semantics"), paths.get("blacklist"), paths.get("objdir"), params,
                     time_limit, output, "planet-toml")


def load_planet_params(path: str | Path, report: LoadReport | None = None
                       ) -> tuple[tuple[str, object], ...]:
    """planet's params TOML -> (name, value) pairs in file order (unknown keys: W500)."""
    r = TomlReader(read_source(path, "params"), report or LoadReport(), legacy=True)

    def build() -> tuple[tuple[str, object], ...]:
        r.check_keys("", r.data, (), PLANET_PARAMS)
        out = []
        for key, value in r.data.items():
            if key in PLANET_PARAMS:
                with r.part():
                    out.append((key, _param(r, key, value, PLANNER_PARAMS[key][0])))
        return tuple(out)

    params: tuple = ()
    with r.part():
        params = build()
    r.finish()
    return params


# --------------------------------------------------------------------------------------------
# tmit-star problem spec JSON (FACTS 3.3)

_TMIT_PATHS = {"domain": "PDDL domain", "problem": "PDDL problem", "initial_scene": "scene file",
               "predicates": "Lua predicate file", "collision_blocklist": "collision blocklist CSV"}


def _load_tmit(source: SourceFile, report: LoadReport) -> RunConfig:
    r = JsonReader(parse_json(source), report, legacy=True)
    return _finish(r, lambda: _tmit(r))


def _tmit(r: JsonReader) -> RunConfig:
    v = r.obj("", r.doc.value, ("domain", "problem", "initial_scene"),
              ("predicates", "collision_blocklist", "name", "min_steps", "max_steps"),
              ignored=("max_iterations",), what="a problem spec {\"domain\": ..., ...}")
    paths: dict[str, Path] = {}
    for key, what in _TMIT_PATHS.items():
        if key in v:
            with r.part():
                paths[key] = _path(r, r.span("/" + key), "/" + key, v[key], True, what)
    params: list[tuple[str, object]] = []
    with r.part():
        if "name" in v:
            params.append(("name", r.string("/name", v["name"])))
        for key in ("min_steps", "max_steps"):
            if key in v:
                params.append((key, r.integer("/" + key, v[key])))
        steps = dict(params)
        if "min_steps" in steps and "max_steps" in steps and \
                steps["min_steps"] > steps["max_steps"]:
            r.fail("E511", r.span("/max_steps"), f"/max_steps {steps['max_steps']} is below "
                   f"/min_steps {steps['min_steps']}")
    r.finish()
    return RunConfig(r.source.path, paths["domain"], paths["problem"], paths["initial_scene"],
                     paths.get("predicates"), paths.get("collision_blocklist"), None,
                     tuple(params), None, None, "tmit-star-json")


# --------------------------------------------------------------------------------------------
# Registry and entry point

#: format name (= RunConfig.format) -> loader(source, report)
CONFIG_LOADERS: dict[str, Callable[[SourceFile, LoadReport], RunConfig]] = {
    "tmpc-toml": _load_native,
    "planet-toml": _load_planet,
    "tmit-star-json": _load_tmit,
}


def _fail(source: SourceFile, report: LoadReport, code: str, message: str,
          hint: str | None) -> NoReturn:
    raise SceneError(error(code, f"{display_name(source.path)}: {message}",
                           Span(source.path, 0, 1), hint), report.files)


def detect_config_format(source: SourceFile, report: LoadReport | None = None) -> str:
    """``tmit-star-json`` for JSON; for TOML, ``tmpc-toml`` if it has a [problem] table and
    ``planet-toml`` if it has a top-level ``domain``/``scene``."""
    report = report or LoadReport()
    report.files[source.path] = source
    text = source.text.lstrip()
    if text.startswith("{") or source.path.lower().endswith(".json"):
        doc = parse_json(source)
        if isinstance(doc.value, dict) and ("format" in doc.value or "bounds" in doc.value):
            _fail(source, report, "E503", "this is a scene, not a run configuration",
                  "give the manifest TOML, planet run TOML or tmit-star spec that names it")
        return "tmit-star-json"
    r = TomlReader(source, report, legacy=True)
    r.finish()
    data = r.data
    if isinstance(data.get("problem"), dict):
        return "tmpc-toml"
    if "domain" in data or "scene" in data:
        return "planet-toml"
    if data and set(data) <= set(PLANET_PARAMS):
        _fail(source, report, "E503", "this is a planet params file, not a run configuration",
              "give the planet run TOML whose `params` names this file")
    _fail(source, report, "E503", "cannot tell which kind of run configuration this is",
          "a native manifest has a [problem] table (docs/world.md); a planet run TOML has "
          "domain/problem/scene keys; a tmit-star spec is JSON")


def load_config(path: str | Path, fmt: str | None = None,
                report: LoadReport | None = None) -> RunConfig:
    """Read and check a run configuration. ``fmt``: a key of :data:`CONFIG_LOADERS` (detected
    when None). Raises SceneError; warnings go to ``report``."""
    report = report if report is not None else LoadReport()
    source = read_source(path, "configuration")
    report.files[source.path] = source
    if fmt is None:
        fmt = detect_config_format(source, report)
    elif fmt not in CONFIG_LOADERS:
        raise SceneError(error("E503", f"unknown configuration format \"{fmt}\"", None, join_hints(
            did_you_mean(fmt, CONFIG_LOADERS), "the formats are " + ", ".join(CONFIG_LOADERS))))
    return CONFIG_LOADERS[fmt](source, report)


def is_run_config(path: str | Path) -> bool:
    """A run configuration (TOML, or a tmit-star spec JSON with ``initial_scene``) rather than a
    scene. Unreadable or malformed files answer False: the scene loader then reports them."""
    import json
    path = Path(path)
    if path.suffix.lower() == ".toml":
        return True
    if path.suffix.lower() != ".json":
        return False
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return False
    return isinstance(data, dict) and "initial_scene" in data

