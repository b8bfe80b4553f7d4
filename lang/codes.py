"""The vocabulary of diagnostic codes: every code tmpc can report, its severity and meaning.

Each user-facing problem is a :class:`~tmpc.lang.diagnostics.Diagnostic` with a code such as
``E582`` (an error) or ``W614`` (a warning). This module is the one table of those codes:
:data:`CODES` maps each code to a :class:`Code` (code, severity, one-line meaning), and
:func:`lookup` finds one. :func:`tmpc.lang.diagnostics.error` and
:func:`~tmpc.lang.diagnostics.warning` refuse a code that is not here, or one whose severity
differs from the table's, so a mistyped code cannot ship.

``docs/diagnostics.md`` documents the same codes, grouped by topic, with the same meanings;
``tests/lang/test_codes.py`` keeps the two, and the codes the sources use, in step. To add a
code: add a row here and in the docs, then use it. A code is never reused for another fault.

Severities are the values of :class:`tmpc.lang.diagnostics.Severity`: ``"error"`` for ``E…``
codes, ``"warning"`` for ``W…`` codes, and ``"note"`` for a ``W…`` code reported as a note
(W613; its row in the docs starts with "(note)").

Standard library only: ``tmpc.lang`` stays light.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

ERROR, WARNING, NOTE = "error", "warning", "note"
SEVERITIES = (ERROR, WARNING, NOTE)


@dataclass(frozen=True, slots=True)
class Code:
    """One diagnostic code: ``code`` (``E582``), ``severity`` (``"error"``, ``"warning"``,
    ``"note"``) and a one-line ``meaning`` (the row of ``docs/diagnostics.md``)."""

    code: str
    severity: str
    meaning: str


_TABLE = (
    # Syntax (brackets, tokens)
    Code("E001", ERROR, "missing `)`: reported where the `)` belongs (found by indentation), with "
                        "the unclosed `(` as a related location"),
    Code("E002", ERROR, "unexpected `)`: one too many (found by indentation) or with no `(` at "
                        "all"),
    Code("E003", ERROR, "unterminated string"),
    Code("E004", ERROR, "parentheses nested deeper than the limit (100 levels): the file is not "
                        "read further"),
    Code("E010", ERROR, "a file cannot be read (missing, a directory, no permission)"),
    Code("E011", ERROR, "a file is not UTF-8 text"),

    # Structure (domains, problems, actions)
    Code("E100", ERROR, "the file contains no `(define ...)`"),
    Code("E101", ERROR, "a top-level form that is not `(define (domain|problem|module NAME) ...)`"),
    Code("E102", ERROR, 'unknown section keyword (with a "did you mean")'),
    Code("E103", ERROR, "`:parameters`/`:precondition`/`:effect` outside an action (an earlier "
                        "`)` closed it)"),
    Code("E104", ERROR, "expected a section or a list here"),
    Code("E105", ERROR, "a section given twice"),
    Code("E106", ERROR, "unknown action key (e.g. `:precondtion`, `:effects`)"),
    Code("E107", ERROR, "an action key without a value"),
    Code("E108", ERROR, "an action key given twice"),
    Code("E109", ERROR, "something other than a key inside an action (e.g. the next `(:action` "
                        "when a `)` is missing)"),
    Code("E110", ERROR, "malformed typed list: `-` without a type, a type with no names before "
                        "it, `?x - ?y`"),
    Code("E111", ERROR, "malformed formula (`not` with two arguments, a section keyword inside a "
                        "formula, ...)"),
    Code("E112", ERROR, "malformed effect (`or`/`exists` in an effect, `not` of a non-atom, ...)"),
    Code("E113", ERROR, "malformed expression in a `:semantics` or `:define` body"),
    Code("E114", ERROR, "expected a number"),
    Code("E115", ERROR, 'unknown requirement (with a "did you mean")'),
    Code("E116", ERROR, "malformed predicate annotation (`:kinematic`, `:semantics`, ...)"),
    Code("E117", ERROR, "expected a name here"),
    Code("E118", ERROR, "expected a `?variable` here"),
    Code("E120", ERROR, "a problem section in a domain, or a domain section in a problem"),
    Code("E121", ERROR, "timed initial literals (not supported)"),
    Code("E122", ERROR, "a module defines actions"),
    Code("E123", ERROR, "an `:include` names a module that does not exist"),
    Code("E124", ERROR, "a module includes itself"),
    Code("E125", ERROR, "a semantics module is malformed: no `(define (semantics ...))`, or a "
                        "kinematic parent or carried action without the module's `(:hand FRAME)`"),
    Code("E126", ERROR, "a semantics module gives a predicate another number of arguments than "
                        "the domain declares"),
    Code("E127", ERROR, "a semantics module names an action the domain does not have"),
    Code("E128", ERROR, "`:carries` names no parameter of the action"),

    # Names and types
    Code("E200", ERROR, "unknown predicate (or a derived predicate not declared in `:predicates`)"),
    Code("E201", ERROR, "a name defined twice (predicate, action, helper, object, parameter)"),
    Code("E202", ERROR, "wrong number of arguments"),
    Code("E203", ERROR, "unknown type of a helper parameter or an expression quantifier"),
    Code("E204", ERROR, "an argument's type does not fit the parameter"),
    Code("E205", ERROR, "unknown `?variable`"),
    Code("E206", ERROR, "unknown object or constant"),
    Code("E207", ERROR, "cyclic type hierarchy"),
    Code("E208", ERROR, "unknown function (numeric fluent)"),
    Code("E209", ERROR, "a problem names another domain"),
    Code("E210", ERROR, "no domain found for a problem"),
    Code("E211", ERROR, "a command expected exactly one domain and problem"),

    # Expressions (`:semantics`, `:define`)
    Code("E300", ERROR, "a type error (wrong argument types for an operator or helper, "
                        "non-boolean condition)"),
    Code("E301", ERROR, "unknown operator or helper"),
    Code("E302", ERROR, "an `if` condition that depends on the robot/object state (must be "
                        "static)"),
    Code("E303", ERROR, "a `:semantics` body that is not a condition"),
    Code("E304", ERROR, "a helper that calls itself (helpers are inlined)"),

    # Predicate kinds
    Code("E400", ERROR, "a geometric predicate in an effect (its value follows from the geometry)"),
    Code("E401", ERROR, "a discrete or kinematic predicate inside a `:semantics` body"),
    Code("E402", ERROR, "a kinematic annotation naming something that is not a parameter, or "
                        "linking an object to itself"),
    Code("E404", ERROR, "a geometric predicate in `:init`"),
    Code("E405", ERROR, "an effect on a derived predicate"),
    Code("E406", ERROR, "an action cost that is negative or not finite (`1e400` reads as "
                        "infinity)"),

    # Grounding
    Code("E600", ERROR, "an action or derived rule with too many parameter bindings (objects per "
                        "parameter multiplied, after narrowing by unary static preconditions; "
                        "default limit 2,000,000): the message gives each parameter's count"),
    Code("E601", ERROR, "a `forall`/`exists` (precondition, goal, derived rule) or a `forall` "
                        "effect that expands to a formula larger than the grounding limit"),
    Code("E602", ERROR, "numeric state: a numeric effect other than `(increase (total-cost) "
                        "...)`, a conditional cost, or a condition comparing `total-cost`"),
    Code("E603", ERROR, "an action cost that reads a numeric fluent with no value in `:init`"),
    Code("E604", ERROR, "derived predicates that cannot be stratified (one depends on its own "
                        "negation)"),
    Code("E605", ERROR, "a domain without a problem given where a ground problem is needed"),

    # Task planning
    Code("E610", ERROR, "`--min-steps`/`--max-steps` negative or out of order, `--time-limit` "
                        "not positive, or `--min-steps` with `--engine astar` (exit 2)"),
    Code("E611", ERROR, "no plan: the goal is unreachable even ignoring delete effects; names the "
                        "goal atoms no action sequence makes true (exit 3)"),
    Code("E612", ERROR, "no plan of any length up to `--max-steps` (every horizon proven "
                        "impossible; exit 3)"),
    Code("E613", ERROR, "the time limit ran out; says which plan lengths were ruled out (exit 3)"),
    Code("E615", ERROR, "the two files given to `tmpc plan` are not one domain and one problem "
                        "for it"),
    Code("E616", ERROR, "no plan exists: A* (`--engine astar` or `auto`) explored every "
                        "reachable state (exit 3)"),
    Code("W610", WARNING, "an action whose precondition is contradictory (unsatisfiable as a "
                          "propositional formula): it can never be applied"),
    Code("W611", WARNING, "an action none of whose ground instances is reachable in the problem "
                          "(with the reason when simple: no objects of a parameter type, a static "
                          "predicate without facts, a predicate no reachable atom has)"),
    Code("W612", WARNING, "a goal unreachable in the delete relaxation, naming the goal atoms no "
                          "action sequence makes true"),
    Code("W613", NOTE, "a static check did not run within its time budget, or the problem is too "
                       "large to ground quickly: result unknown"),
    Code("W614", WARNING, "a geometric predicate or an action's geometric precondition held in "
                          "none of 256 projections from uniform configurations within the joint "
                          "and base bounds, for up to 4 of its ground instances, objects where "
                          "the scene puts them: it may be unsatisfiable in this scene (sampling "
                          "cannot prove it; the smallest distance left is given)"),

    # Task and motion planning (`tmpc run`)
    Code("E834", ERROR, "a geometric goal atom over objects that never move (no movable object, no "
                        "robot frame) that is false in the scene: no plan can make it true"),
    Code("E820", ERROR, "`tmpc run` was given a scene alone (or a configuration without a "
                        "problem): it needs a domain and a problem"),
    Code("E821", ERROR, "the scene has no robot to plan for"),
    Code("E822", ERROR, "objects named by the problem's geometric atoms are neither scene objects "
                        "nor robot frames (a scene/PDDL mismatch)"),
    Code("E823", ERROR, "the start state is in collision; the message names the colliding pairs "
                        "and their depths"),
    Code("E824", ERROR, "the goal is unreachable even in the delete relaxation (ignoring "
                        "geometry), so no plan exists"),
    Code("E825", ERROR, "a planner parameter out of range (e.g. a heuristic bias outside [0, 1])"),
    Code("E826", ERROR, "an unknown planner name; the hint lists the planners"),
    Code("E827", ERROR, "a PDDL file given where a run configuration or scene is expected (`run`, "
                        "`eval`, `sample`, `validate`, `view`, `compile`); the hint shows the "
                        "manifest and `tmpc plan`"),
    Code("E828", ERROR, "a plan or results file cannot be written (missing folder, no permission)"),
    Code("E829", ERROR, "a start configuration outside the robot's joint limits (or a mobile base "
                        "outside the scene bounds)"),

    # Benchmarks (`tmpc bench`)
    Code("E830", ERROR, "an output (`-o`, `--ompl-log`) that cannot be written: a directory, no "
                        "such directory, or a directory without write permission"),
    Code("E831", ERROR, "`tmpc bench --backend ray` without Ray installed; the hint names the "
                        "`cluster` extra"),

    # Internal
    Code("E900", ERROR, "`fmt` would have changed a file's meaning or comments; the file was left "
                        "alone (a bug: please report)"),

    # Warnings
    Code("W001", WARNING, "a feature used without its requirement flag (not reported for legacy "
                          "files)"),
    Code("W002", WARNING, "an action parameter that is never used"),
    Code("W003", WARNING, "a requirement tmpc accepts but does not plan with (durative actions, "
                          "preferences, ...)"),
    Code("W004", WARNING, "a geometric predicate in an effect of a legacy file: ignored, as "
                          "planet did"),
    Code("W005", WARNING, "`:effect` before `:precondition`"),
    Code("W006", WARNING, "a negative fact in `:init` (redundant under the closed world)"),
    Code("W009", WARNING, "a type in a typed list with no names before it"),
    Code("W010", WARNING, "a problem object that repeats a domain constant"),
    Code("W011", WARNING, "a problem given alone was checked with the domain found beside it"),
    Code("W012", WARNING, "a type used but not declared: taken as a subtype of `object`"),
    Code("W013", WARNING, "a domain names an object that is not one of its constants"),
    Code("W014", WARNING, "a repeated parameter name in a predicate or function declaration"),
    Code("W015", WARNING, "a legacy `:init` fact naming an undeclared object: ignored, as the "
                          "original planners did"),
    Code("W016", WARNING, "a local predicate or helper shadows an included helper of the same "
                          "name"),
    Code("W017", WARNING, "an extra `)` in a legacy planet/tmit-star file: tolerated"),
    Code("W018", WARNING, "a planet domain names a constant it does not declare (a robot link, "
                          "as planet's clutter_nohit does): read as a robot frame or scene object"),

    # Scenes and configurations
    Code("W019", WARNING, "a semantics module names another domain than the one it is used with"),
    Code("W020", WARNING, "a semantics module's action gives parameters: the domain's are used, "
                          "these are ignored"),
    Code("W021", WARNING, "an `:init` atom of a predicate a semantics module makes geometric: "
                          "the scene decides its value, the atom is ignored"),
    Code("E500", ERROR, "malformed JSON (with the position; trailing commas, comments, single "
                        "quotes, NaN, a key given twice)"),
    Code("E501", ERROR, "malformed XML in a planet scene"),
    Code("E502", ERROR, "malformed TOML in a run configuration or params file"),
    Code("E503", ERROR, "the format of a scene or configuration cannot be told (or an unknown "
                        "format name was asked for)"),
    Code("E504", ERROR, 'an unknown key in a native scene or manifest (with a "did you mean")'),
    Code("E505", ERROR, "a required key or XML element is missing"),
    Code("E506", ERROR, 'a value of the wrong type (a string for a number, `"true"` for `true`, '
                        "...)"),
    Code("E507", ERROR, "an array or number list of the wrong length (a translation needs 3 "
                        "numbers, a planet pose 12)"),
    Code("E508", ERROR, "a quaternion whose norm is not within 1e-3 of 1 (quaternions are x, y, "
                        "z, w)"),
    Code("E509", ERROR, "a planet pose whose 3x3 part is not a rotation (not orthonormal within "
                        "1e-3, or a reflection)"),
    Code("E510", ERROR, "an object name (or controllable joint) given twice; names are compared "
                        "without case"),
    Code("E511", ERROR, "an empty interval: bounds, support region or `sssp` with low above high; "
                        "`min_steps` above `max_steps`"),
    Code("E512", ERROR, "a negative size (radius, length, half-extent, scale), a negative, zero or "
                        "non-finite parameter that must be positive, or a probability above 1"),
    Code("E513", ERROR, "an unknown parent, a parent loop, or an allowed-collision pair naming "
                        "nothing in the scene"),
    Code("E514", ERROR, "a mesh file that cannot be found (with strict meshes, as `tmpc check` "
                        "loads scenes and run configurations; the hint lists where tmpc looked)"),
    Code("E515", ERROR, "a file named by a run configuration (domain, problem, scene, ...) or a "
                        "scene's allowed-collision CSV that cannot be found"),
    Code("E516", ERROR, "a malformed line in an allowed-collision CSV (expected `nameA,nameB`)"),
    Code("E517", ERROR, "an unknown shape type (native: box, sphere, cylinder, mesh; tmit-star: "
                        "box)"),
    Code("E518", ERROR, "an object name that cannot be written in PDDL (spaces, brackets, quotes, "
                        "`;`)"),
    Code("E519", ERROR, "an unknown native scene format version (this version reads "
                        "`tmpc-scene/1`)"),
    Code("E520", ERROR, "a position (object, robot base, workspace bound) more than 10 km from "
                        "the origin: a typo or a unit mix-up"),
    Code("E521", ERROR, "an attachment (planet `<attachments>`, native `attachments`) naming no "
                        'object of the scene (with a "did you mean")'),
    Code("E522", ERROR, "an object attached to itself, to two objects, or attachments forming a "
                        "loop"),
    Code("E523", ERROR, "a grasp or stable-pose axis that is the zero vector"),
    Code("E524", ERROR, "a run manifest's `[names]` entry naming no object of the scene (with a "
                        '"did you mean")'),
    Code("E525", ERROR, "a run manifest's `[names]` giving one scene object two PDDL names, or a "
                        "PDDL name that another scene object already has"),
    Code("W301", WARNING, "a division by a constant zero in a `:semantics` or `:define` body: the "
                        "value is always +inf, -inf or nan"),
    Code("W500", WARNING, "an unknown key or XML element in a legacy file: ignored, as the "
                          "original planner did"),
    Code("W501", WARNING, "a mesh file that cannot be found, loading with strict meshes off: kept "
                          "as a path, not checked"),
    Code("W502", WARNING, "a legacy joint value for a joint the URDF does not have: ignored"),
    Code("W503", WARNING, "a tmit-star object with both `obj_file` and `shape`: `obj_file` is "
                          "used, as tmit-star did"),
    Code("W504", WARNING, "tmit-star surface bounds under a rotation that does not map axes to "
                          "axes: approximated by a larger box"),
    Code("W505", WARNING, "a planet scene without `<workspace_bounds>`: derived from the objects' "
                          "and robot's positions plus 2 m"),
    Code("W506", WARNING, "a planet scene with more than one `<robot>`: only the first is used"),
    Code("W507", WARNING, "a run configuration's `output` that cannot be written (no such folder, "
                        "no permission): `tmpc run` refuses it before planning"),
    Code("W508", WARNING, "a planet scene's `pr2.urdf` that does not exist: example-robot-data's "
                          "PR2 model is used (the message names the file)"),
    Code("W509", WARNING, "a planet grasp set whose `type` is not `side` or `top`: kept as written"),
    Code("W510", WARNING, "a PDDL problem file that ends before the `)` closing its `(define`: "
                          "closed at the end of the file (the Lagriffoul suite's problems)"),

    # Robots
    Code("W517", WARNING, "a movable object written at the place of another is moved to the "
                          "nearest free place"),
    Code("W518", WARNING, "a flat support region floating up to 3 cm above its object's mesh "
                          "is lowered onto the mesh"),
    Code("W519", WARNING, "a robot base far from its scene's floor (the lowest fixed object's "
                          "origin) is put on the floor"),
    Code("E560", ERROR, "a URDF (path or `package://` URI) that cannot be found; the hint lists "
                        "where tmpc looked"),
    Code("E561", ERROR, "a malformed URDF (bad XML, unknown links, not a tree, mimic of an "
                        "unknown joint)"),
    Code("E562", ERROR, "a mesh of a URDF link that cannot be found"),
    Code("E563", ERROR, "a floating or planar joint in a URDF (a mobile base is set in the scene "
                        "instead)"),
    Code("E564", ERROR, "a scene naming a joint the robot does not have, or a fixed/mimic joint "
                        "as controllable"),
    Code("E565", ERROR, "a collision mesh (robot link or scene object) that trimesh cannot load "
                        "or that has no triangles (`tmpc check`: a scene's mesh file that is "
                        "unreadable, empty, or an STL/OBJ/PLY file without triangles)"),
    Code("E566", ERROR, "an object the scene marks static that an action can hold, or that a "
                        "collision check moves or holds"),
    Code("E567", ERROR, "a collision check naming an object the scene does not have (or one "
                        "without a shape)"),
    Code("E568", ERROR, "a held object's frame, or an `attach_allowed` link, that is no link or "
                        "joint of the robot"),
    Code("E569", ERROR, "an object whose `parent` names nothing (no object, link or joint), or "
                        "parents that form a loop"),
    Code("E570", ERROR, "an SRDF beside the URDF (or given) that is not readable XML"),
    Code("E572", ERROR, "a negative or non-finite penetration tolerance"),
    Code("E573", ERROR, "a configuration of the wrong shape, or an object pose that is not a "
                        "finite 4x4 matrix"),
    Code("E574", ERROR, "a degenerate collision shape (zero or negative size, unknown kind, mesh "
                        "without a file)"),
    Code("E575", ERROR, "a motion resolution that is not a finite number > 0"),

    # States
    Code("E580", ERROR, "a malformed state JSON (unknown joint/object/frame, wrong shape, "
                        "non-unit quaternion); the message gives the JSON path"),
    Code("E581", ERROR, "an expression that cannot be evaluated at a state (`tmpc eval`: unknown "
                        "name or joint, wrong value types, a surface without a support region)"),
    Code("E582", ERROR, "`tmpc eval --predicate` / `tmpc sample`: an unknown predicate"),
    Code("E583", ERROR, "a geometric predicate implemented in Lua whose file was not given"),
    Code("E584", ERROR, "`tmpc sample` on a scene without a robot"),
    Code("E585", ERROR, "a scene alone where a domain is needed (`tmpc compile`, `tmpc sample`, "
                        "`tmpc eval --predicate`), or `tmpc compile` without a run configuration "
                        "and missing `--domain/--problem/--scene`"),
    Code("E586", ERROR, "`tmpc eval --predicate` / `tmpc sample`: a predicate that is not "
                        "geometric (discrete or kinematic)"),
    Code("E587", ERROR, "`tmpc sample --action`: an unknown action"),
    Code("E588", ERROR, "`tmpc eval --predicate` / `tmpc sample`: the wrong number of arguments "
                        "for the predicate or action"),
    Code("E589", ERROR, "`tmpc eval --predicate` / `tmpc sample`: an argument that is neither a "
                        "scene object nor a robot frame"),
    Code("E590", ERROR, "not a usable artifact: not a zip, no manifest, another format version, a "
                        "missing, damaged or modified member"),
    Code("E592", ERROR, "`tmpc compile -o`: an artifact path that cannot be written (a directory, "
                        "no such directory, no permission)"),
    Code("E591", ERROR, "`tmpc eval --predicate` / `tmpc sample`: an argument whose type does not "
                        "fit the parameter"),

    # Repair (`tmpc repair`)
    Code("E840", ERROR, "a repair store that cannot be opened or is not a repair store"),
    Code("E841", ERROR, "a repair store in use by another process"),
    Code("E842", ERROR, "a repair store made for another domain, action or run"),
    Code("E843", ERROR, "a malformed line of an observations file (file:line)"),
    Code("E844", ERROR, "`tmpc repair --action`: an unknown action, wrong arguments, or a "
                        "precondition repair cannot read"),
    Code("E845", ERROR, "a formula or template that does not fit the action's parameters or is "
                        "not made of templates"),
    Code("E846", ERROR, "`tmpc repair`: a missing or malformed option (--controller, "
                        "--observations, --db)"),
    Code("E847", ERROR, "`tmpc repair --experiment`: an unknown experiment or a missing manifest "
                        "or truth file"),
    Code("E848", ERROR, "the repaired domain could not be written back"),
    Code("E849", ERROR, "a repair store that already holds observations, without --resume"),

    # OMPL inside tmpc: the decoupled planner, `tmpc motion`, `--simplify ompl` (issue Q)
    Code("E850", ERROR, "an unknown motion planner (`--motion-planner`, `tmpc motion "
                        "--planner`): not `tmpc` or an `ompl:NAME` tmpc lists"),
    Code("E851", ERROR, "`--planner decoupled`: a motion budget, a number of motion checks "
                        "or of transition samples out of range"),
    Code("E852", ERROR, "`tmpc motion`: `--from`/`--to`/`--mode` neither `start`, `random` nor a"
                        " state file"),
    Code("E853", ERROR, "`tmpc motion`: an end state in collision or outside the joint limits"),
    Code("E854", ERROR, "`tmpc motion --from/--to random`: no collision-free random state found"),
    Code("E855", ERROR, "an unknown simplifier (`--simplify`, the API's `simplify=`): not `tmpc` "
                        "or `ompl`"),
    Code("E857", ERROR, "OMPL cannot be imported (`--motion-planner ompl:...`, `--simplify "
                        "ompl`, `tmpc motion`)"),

    # Plans (`tmpc validate`, `tmpc view`)
    Code("E800", ERROR, "a plan file that cannot be read or is not valid JSON"),
    Code("E801", ERROR, "a plan file that is neither a tmpc plan object nor an array of states"),
    Code("E802", ERROR, "a plan `format` other than `tmpc-plan/1`"),
    Code("E803", ERROR, "no `states`, `states` not a list, or an empty one"),
    Code("E804", ERROR, "a state that is not an object, or has a field other than `joints`, "
                        "`base_pose`, `object_poses`, `action`, `mode`"),
    Code("E805", ERROR, "`joints` not an object, or a joint value that is not a finite number"),
    Code("E806", ERROR, "a malformed pose (`base_pose`, `object_poses`): not an object, unknown "
                        "field, not 3/4 finite numbers, a quaternion whose norm is not 1"),
    Code("E807", ERROR, "`object_poses` that is not an object"),
    Code("E808", ERROR, 'an action that is not a string `"(name arg ...)"`, a list `[name, arg, '
                        "...]` or null, or cannot be read"),
    Code("E809", ERROR, "a malformed `mode` (not an object, unknown field, `atoms` not a list, "
                        "`held` not an object of strings)"),
    Code("E810", ERROR, 'a mode atom that cannot be read as `"(predicate arg ...)"`'),
    Code("E811", ERROR, "a top-level `status` that is not a string, or `actions` that is not a "
                        "list of strings"),
    Code("E812", ERROR, "`tmpc validate` given a scene alone: it needs the run configuration "
                        "(domain and problem) the plan was made for"),
    Code("E813", ERROR, "a `--tolerance` that is negative or not finite, or a `--resolution` that "
                        "is not a finite number > 0"),
    Code("W830", WARNING, "`tmpc validate`: a released object that does not rest on a support "
                          "(its gap above the surface > 1 cm, or tilted > 5°); an error with "
                          "--strict"),
    Code("W840", WARNING, "an `:init` atom whose semantics-module meaning is false in the scene: "
                          "the PDDL file and the scene disagree (a placement on a fixed support "
                          "the scene puts elsewhere: plans start from the scene's, named in the "
                          "hint)"),
    Code("E817", ERROR, "a plan made for another problem: it names joints the robot does not have "
                        "or objects the scene does not (`validate`, `view`)"),
    Code("E818", ERROR, "a state's `t` that is not a finite number >= 0, or is before the "
                        "previous state's (a timed plan)"),
    Code("E819", ERROR, "`tmpc export` or `tmpc simulate` given a plan without times (time it "
                        "first: `tmpc time`, `tmpc run --timed`)"),
    Code("E832", ERROR, "a plan that cannot be timed: no robot, its URDF not found, or a motion "
                        "toppra finds no profile for (`tmpc time`, `run --timed`)"),
    Code("E833", ERROR, "`tmpc simulate`: MuJoCo is not installed, or cannot build the robot or "
                        "scene (the message says which part)"),
    Code("E835", ERROR, "`tmpc simulate --html`: the page cannot be written (no such directory, "
                        "no permission)"),
    Code("E814", ERROR, "`tmpc view --state I` (a PNG snapshot) with no state I in the plan"),
    Code("E815", ERROR, "a viewer output (`--html`, `--png`) that cannot be written (no such "
                        "directory, no permission)"),
    Code("E816", ERROR, "the viewer's script (`viewer_assets/viewer.js`, package data) missing "
                        "from the installation"),

    # Lua
    Code("E700", ERROR, "a Lua syntax error (file and line)"),
    Code("E701", ERROR, "a Lua runtime error while the file itself runs (its top-level code)"),
    Code("E702", ERROR, "a Lua runtime error inside a predicate function (wrong value kinds: a "
                        "combinator given a number, arithmetic on a condition, indexing nil, ...)"),
    Code("E703", ERROR, "something tmpc's Lua sandbox does not provide: `os`, `io`, `debug`, "
                        "`load*`, `dofile`, `package`, `coroutine`, `string.dump`, string pattern "
                        "matching, `__gc`, `require` of a module other than `'tmit-star'`"),
    Code("E704", ERROR, "a Lua call ran past its instruction budget (an infinite loop?)"),
    Code("E705", ERROR, "the Lua file's memory cap was exceeded"),
    Code("E706", ERROR, "a predicate function returned the wrong kind of value (planet: a "
                        "condition; tmit-star: a distance number)"),
    Code("E707", ERROR, "a geometric predicate without inline semantics and without a Lua "
                        "function of its name"),
    Code("E708", ERROR, "a Lua function's parameter count differs from its PDDL predicate's arity"),
    Code("E709", ERROR, "an unknown or unsupported field of a predicate argument (planet `sop`, "
                        "`grasps`, `sssp.plane`; a surface field of an argument without a support "
                        "region)"),
    Code("E710", ERROR, "a Lua file returning something other than nothing (planet) or a table "
                        "(tmit-star), or not in the dialect asked for"),
    Code("W700", WARNING, "a Lua predicate tmpc cannot trace (it branches on the state or calls a "
                          "function with no IR operator): evaluated directly per state, with "
                          "dual-number gradients"),
)

#: every diagnostic code, in the order of ``docs/diagnostics.md``
CODES: Mapping[str, Code] = {c.code: c for c in _TABLE}
if len(CODES) != len(_TABLE):
    raise AssertionError("a diagnostic code is listed twice in tmpc.lang.codes")


def lookup(code: str) -> Code:
    """The entry for ``code``; :class:`KeyError` naming the code if it is not in the vocabulary."""
    try:
        return CODES[code]
    except KeyError:
        raise KeyError(f"unknown diagnostic code {code!r} (not in tmpc.lang.codes; "
                       "add it there and to docs/diagnostics.md)") from None


def is_code(code: str) -> bool:
    """Whether ``code`` is in the vocabulary."""
    return code in CODES


__all__ = ["Code", "CODES", "lookup", "is_code", "ERROR", "WARNING", "NOTE", "SEVERITIES"]
