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
