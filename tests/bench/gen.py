"""Synthetic large inputs for the front-end benchmarks (deterministic)."""

from __future__ import annotations


def big_domain(n_actions: int = 60) -> str:
    """A typed ADL domain of about 15 lines per action, with a tmpc geometric predicate."""
    lines = ["; synthetic benchmark domain", "(define (domain bench)",
             "  (:requirements :strips :typing :negative-preconditions :conditional-effects :tmpc)",
             "  (:types room item robot - object heavy light - item)",
             "  (:predicates"]
    for i in range(n_actions):
        lines.append(f"    (at{i} ?r - robot ?x - room)")
        lines.append(f"    (has{i} ?r - robot ?i - item)")
    lines.append("    (near ?r - robot ?i - item :semantics "
                 "(<= (distance (position ?r) (position ?i)) 0.2)))")
    for i in range(n_actions):
        lines += [
            f"  (:action move{i}",
            "    :parameters (?r - robot ?from ?to - room ?i - item)",
            "    :precondition (and",
            f"      (at{i} ?r ?from)",
            f"      (not (at{i} ?r ?to))",
            "      (near ?r ?i)",
            f"      (has{i} ?r ?i))",
            "    :effect (and",
            f"      (at{i} ?r ?to)",
            f"      (not (at{i} ?r ?from))",
            f"      (when (has{i} ?r ?i)",
            f"        (and (has{(i + 1) % n_actions} ?r ?i)",
            f"             (not (has{i} ?r ?i))))",
            "      ; keep the item",
            f"      (has{i} ?r ?i)))",
        ]
    lines.append(")")
    return "\n".join(lines) + "\n"


def big_problem(n_facts: int = 1000) -> str:
    lines = ["(define (problem bench-1)", "  (:domain bench)", "  (:objects",
             "    " + " ".join(f"room{i}" for i in range(40)) + " - room",
             "    " + " ".join(f"box{i}" for i in range(40)) + " - heavy",
             "    robot1 robot2 - robot)", "  (:init"]
    for k in range(n_facts):
        lines.append(f"    (at{k % 60} robot{1 + k % 2} room{k % 40})")
    lines += ["  )", "  (:goal (and (at0 robot1 room39) (has1 robot2 box3))))"]
    return "\n".join(lines) + "\n"


def logistics_domain() -> str:
    """A small typed domain for :func:`large_problem` (unary to ternary predicates, a function)."""
    return """(define (domain big-logistics)
  (:requirements :strips :typing :numeric-fluents)
  (:types place - object city location - place truck package - object)
  (:predicates
    (in-city ?l - location ?c - city)
    (at ?p - package ?l - location)
    (truck-at ?t - truck ?l - location)
    (road ?a ?b - location)
    (delivered ?p - package)
    (route ?t - truck ?a ?b - location))
  (:functions (weight ?p - package))
  (:action drive
    :parameters (?t - truck ?a ?b - location)
    :precondition (and (truck-at ?t ?a) (road ?a ?b) (route ?t ?a ?b))
    :effect (and (truck-at ?t ?b) (not (truck-at ?t ?a))))
  (:action deliver
    :parameters (?t - truck ?p - package ?l - location)
    :precondition (and (truck-at ?t ?l) (at ?p ?l))
    :effect (and (delivered ?p) (not (at ?p ?l)))))
"""


def large_problem(target_bytes: int) -> str:
    """A problem for :func:`logistics_domain` of about ``target_bytes`` characters: objects in
    typed groups (a tenth of the text) and `:init` facts of arity 1-3 with some numeric ones and
    a comment now and then, laid out as `tmpc fmt` would not (so `fmt` has work to do).
    Deterministic; the shape of a generated large real problem."""
    n = max(10, target_bytes // 118)       # ~118 characters of text per package
    cities, locs, trucks = max(2, n // 100), max(4, n // 4), max(2, n // 20)
    out = ["; generated large problem (tests/bench/gen.py)", "(define (problem big-1)",
           "  (:domain big-logistics)", "  (:objects"]
    for name, count, typ in (("city", cities, "city"), ("loc", locs, "location"),
                             ("truck", trucks, "truck"), ("pkg", n, "package")):
        words = [f"{name}{i}" for i in range(count)]
        for k in range(0, count, 12):
            out.append("    " + " ".join(words[k:k + 12]) + (f" - {typ}" if k + 12 >= count
                                                             else ""))
    out += ["  )", "  (:init"]
    for i in range(locs):
        out.append(f"    (in-city loc{i} city{i % cities})")
        out.append(f"    (road loc{i} loc{(i * 7 + 1) % locs})")
    for i in range(trucks):
        out.append(f"    (truck-at truck{i} loc{(i * 13) % locs})")
    for i in range(n):
        if i % 1000 == 0:
            out.append(f"    ; packages from {i}")
        out.append(f"    (at pkg{i} loc{(i * 31) % locs})  (= (weight pkg{i}) {i % 97})")
        out.append(f"    (route truck{i % trucks} loc{i % locs} loc{(i * 7 + 1) % locs})")
        if i % 3 == 0:
            out.append(f"    (delivered pkg{i})")
    out += ["  )", "  (:goal (and (delivered pkg0) (at pkg1 loc0))))"]
    return "\n".join(out) + "\n"


#: the classic two-room gripper domain (STRIPS, typed), written here from its well-known
#: definition: a robot with two grippers carries balls from one room to the other
GRIPPER_DOMAIN = """(define (domain gripper)
  (:requirements :strips :typing)
  (:types room ball gripper)
  (:predicates (at-robby ?r - room) (at ?b - ball ?r - room) (free ?g - gripper)
               (carry ?b - ball ?g - gripper))
  (:action move :parameters (?from ?to - room)
    :precondition (at-robby ?from)
    :effect (and (at-robby ?to) (not (at-robby ?from))))
  (:action pick :parameters (?b - ball ?r - room ?g - gripper)
    :precondition (and (at ?b ?r) (at-robby ?r) (free ?g))
    :effect (and (carry ?b ?g) (not (at ?b ?r)) (not (free ?g))))
  (:action drop :parameters (?b - ball ?r - room ?g - gripper)
    :precondition (and (carry ?b ?g) (at-robby ?r))
    :effect (and (at ?b ?r) (free ?g) (not (carry ?b ?g)))))
"""


def gripper_problem(n_balls: int) -> str:
    """All ``n_balls`` balls from room a to room b (the IPC-1998 task of that size; optimal
    length ``4 * n/2 - 1`` moves and carries for even ``n``: 11, 17, 23 for 4, 6, 8)."""
    balls = " ".join(f"ball{i}" for i in range(1, n_balls + 1))
    at = " ".join(f"(at ball{i} rooma)" for i in range(1, n_balls + 1))
    goal = " ".join(f"(at ball{i} roomb)" for i in range(1, n_balls + 1))
    return (f"(define (problem gripper-{n_balls}) (:domain gripper)\n"
            f"  (:objects rooma roomb - room {balls} - ball left right - gripper)\n"
            f"  (:init (at-robby rooma) (free left) (free right) {at})\n"
            f"  (:goal (and {goal})))\n")
