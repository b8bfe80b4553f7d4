"""The vocabulary: keywords, requirements and built-in operators, shared by the reader, checker,
formatter and (later) the language server's completion. Nothing else spells these strings.
"""

from __future__ import annotations

from dataclasses import dataclass

# ---------------------------------------------------------------------------------------------
# Requirements

#: requirement -> requirements it implies (PDDL 3.1 semantics).
REQUIREMENTS: dict[str, tuple[str, ...]] = {
    ":strips": (),
    ":typing": (),
    ":negative-preconditions": (),
    ":disjunctive-preconditions": (),
    ":equality": (),
    ":existential-preconditions": (),
    ":universal-preconditions": (),
    ":quantified-preconditions": (":existential-preconditions", ":universal-preconditions"),
    ":conditional-effects": (),
    ":fluents": (":numeric-fluents", ":object-fluents"),
    ":numeric-fluents": (),
    ":object-fluents": (),
    ":adl": (":strips", ":typing", ":negative-preconditions", ":disjunctive-preconditions",
             ":equality", ":quantified-preconditions", ":existential-preconditions",
             ":universal-preconditions", ":conditional-effects"),
    ":derived-predicates": (),
    ":action-costs": (),
    ":durative-actions": (),
    ":duration-inequalities": (),
    ":continuous-effects": (),
    ":timed-initial-literals": (),
    ":preferences": (),
    ":constraints": (),
    ":tmpc": (),
    # PDDL 1.2 flags still found in old IPC files
    ":domain-axioms": (":derived-predicates",),
    ":subgoal-through-axioms": (),
    ":safety-constraints": (),
    ":expression-evaluation": (),
    ":open-world": (),
    ":true-negation": (),
    ":ucpop": (":adl",),
}

#: Requirements parsed but not planned with (a warning says so).
UNSUPPORTED_REQUIREMENTS = frozenset({
    ":durative-actions", ":duration-inequalities", ":continuous-effects",
    ":timed-initial-literals", ":preferences", ":constraints", ":object-fluents",
    ":subgoal-through-axioms", ":safety-constraints", ":expression-evaluation", ":open-world",
    ":true-negation",
})


def closure(reqs: set[str]) -> set[str]:
    """All requirements implied by ``reqs`` (including themselves)."""
    out, todo = set(), list(reqs)
    while todo:
        r = todo.pop()
        if r not in out:
            out.add(r)
            todo.extend(REQUIREMENTS.get(r, ()))
    return out


# ---------------------------------------------------------------------------------------------
# Structural keywords

DOMAIN_SECTIONS = (":requirements", ":types", ":constants", ":predicates", ":functions",
                   ":include", ":define", ":action", ":derived")
PROBLEM_SECTIONS = (":domain", ":requirements", ":objects", ":init", ":goal", ":metric")
ACTION_KEYS = (":parameters", ":precondition", ":effect", ":vars")
#: Keys that belong inside an action; seen at domain level they mean a `)` closed it too early.
ACTION_ONLY_KEYS = frozenset(ACTION_KEYS)
#: Sections of the other kind of file: seen in a domain they mean a problem section and so on.
PREDICATE_ANNOTATIONS = (":discrete", ":kinematic", ":geometric", ":semantics")

FORMULA_CONNECTIVES = ("and", "or", "not", "imply", "exists", "forall")
EFFECT_CONNECTIVES = ("and", "not", "forall", "when")
NUMERIC_EFFECTS = ("increase", "decrease", "assign", "scale-up", "scale-down")
NUMERIC_COMPARISONS = ("<", "<=", "=", ">=", ">")
NUMERIC_OPS = ("+", "-", "*", "/")
METRIC_DIRECTIONS = ("minimize", "maximize")

#: Reserved value-type names usable on `:define` helper parameters.
VALUE_TYPES = ("scalar", "vec3", "quat", "box", "transform", "bool")

# ---------------------------------------------------------------------------------------------
# Expression language (inside :semantics and :define)

S, V, Q, B, T, BOOL, OBJ = "scalar", "vec3", "quat", "box", "transform", "bool", "object"
#: Special argument kinds: an object (parameter/constant), or a bare name resolved by the world
#: model (joint names), or an axis letter.
JOINT_NAME = "joint-name"


@dataclass(frozen=True, slots=True)
class Signature:
    """One overload: argument types (``variadic`` repeats the last one) -> result type."""

    args: tuple[str, ...]
    result: str
    variadic: bool = False


def _sig(args: str, result: str, variadic: bool = False) -> Signature:
    return Signature(tuple(args.split()) if args else (), result, variadic)


#: Built-in operators -> overloads, checked in order. Documented in docs/language.md.
BUILTINS: dict[str, tuple[Signature, ...]] = {
    # arithmetic
    "+": (_sig("scalar scalar", S, True), _sig("vec3 vec3", V, True)),
    "-": (_sig("scalar", S), _sig("vec3", V), _sig("scalar scalar", S), _sig("vec3 vec3", V)),
    "*": (_sig("scalar scalar", S, True), _sig("scalar vec3", V), _sig("vec3 scalar", V)),
    "/": (_sig("scalar scalar", S), _sig("vec3 scalar", V)),
    "abs": (_sig("scalar", S),), "sqrt": (_sig("scalar", S),), "exp": (_sig("scalar", S),),
    "log": (_sig("scalar", S),), "sin": (_sig("scalar", S),), "cos": (_sig("scalar", S),),
    "tan": (_sig("scalar", S),), "asin": (_sig("scalar", S),), "acos": (_sig("scalar", S),),
    "pow": (_sig("scalar scalar", S),), "atan2": (_sig("scalar scalar", S),),
    "min": (_sig("scalar scalar", S, True),), "max": (_sig("scalar scalar", S, True),),
    "clamp": (_sig("scalar scalar scalar", S),),
    # vectors
    "vec3": (_sig("scalar scalar scalar", V),),
    "norm": (_sig("vec3", S),), "norm1": (_sig("vec3", S),), "dot": (_sig("vec3 vec3", S),),
    "cross": (_sig("vec3 vec3", V),), "distance": (_sig("vec3 vec3", S),),
    "x": (_sig("vec3", S), _sig("object", S)), "y": (_sig("vec3", S), _sig("object", S)),
    "z": (_sig("vec3", S), _sig("object", S)),
    # accessors on the continuous state
    "position": (_sig("object", V), _sig("transform", V)),
    "orientation": (_sig("object", Q), _sig("transform", Q)),
    "transform": (_sig("object", T),),
    "rpy": (_sig("object", V), _sig("quat", V)),
    "roll": (_sig("object", S), _sig("quat", S)),
    "pitch": (_sig("object", S), _sig("quat", S)),
    "yaw": (_sig("object", S), _sig("quat", S)),
    "x-axis": (_sig("object", V), _sig("quat", V)),
    "y-axis": (_sig("object", V), _sig("quat", V)),
    "z-axis": (_sig("object", V), _sig("quat", V)),
    "rotate": (_sig("quat vec3", V),),
    "relative": (_sig("object object", V),),   # position of arg1 in the frame of arg2
    "joint": (_sig(JOINT_NAME, S),),
    "extent": (_sig("object", V),),
    "support-region": (_sig("object", B),),
    # scene data of the Lagriffoul suite's format (stdlib/lagriffoul.tmpc), object frame
    "local-support": (_sig("object", B),),
    "grasp-point": (_sig("object", V),),
    "grasp-axis": (_sig("object", V),),
    "grasp-hand-axis": (_sig("object", V),),
    "stable-up": (_sig("object", V),),
    "base": (_sig("", T),),
    # boxes
    "box": (_sig("vec3 vec3", B),),
    "grow": (_sig("box scalar scalar scalar", B), _sig("box scalar", B)),
    "lower": (_sig("box", V),), "upper": (_sig("box", V),), "center": (_sig("box", V),),
    "inside": (_sig("vec3 box", BOOL),),
    # comparisons and logic
    "<": (_sig("scalar scalar", BOOL),), "<=": (_sig("scalar scalar", BOOL),),
    ">": (_sig("scalar scalar", BOOL),), ">=": (_sig("scalar scalar", BOOL),),
    "=": (_sig("scalar scalar", BOOL), _sig("object object", BOOL)),
    "and": (_sig("bool bool", BOOL, True), _sig("bool", BOOL)),
    "or": (_sig("bool bool", BOOL, True), _sig("bool", BOOL)),
    "not": (_sig("bool", BOOL),),
    "implies": (_sig("bool bool", BOOL),),
}

#: Accessors that read the continuous state (used to decide whether an `if` condition is static).
STATE_ACCESSORS = frozenset({
    "position", "orientation", "transform", "rpy", "roll", "pitch", "yaw", "x-axis", "y-axis",
    "z-axis", "relative", "joint", "base", "x", "y", "z",
})
#: Per-axis components: static when applied to a static vector, state when applied to an object.
COMPONENTS = frozenset({"x", "y", "z"})
#: Accessors that read only fixed scene data (static within a problem).
STATIC_ACCESSORS = frozenset({"extent", "support-region", "local-support", "grasp-point",
                              "grasp-axis", "grasp-hand-axis", "stable-up"})

EXPR_SPECIAL_FORMS = ("let", "if", "forall", "exists")
NUMBER_CONSTANTS = {"pi": 3.141592653589793, "inf": float("inf")}
