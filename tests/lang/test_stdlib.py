"""The DSL standard library type-checks and every helper is usable."""

from __future__ import annotations

import pytest

from tests.support import check
from tmpc.lang.program import Workspace, check_parsed, stdlib_modules

GEOMETRY_USES = {
    "near": "(near ?a ?b 0.1)",
    "planar-distance": "(<= (planar-distance ?a ?b) 0.1)",
    "near-planar": "(near-planar ?a ?b 0.1)",
    "in-box": "(in-box (position ?a) (support-region ?b))",
    "on-support": "(on-support ?a ?b)",
    "on-support-within": "(on-support-within ?a ?b 0.01)",
    "support-margin": "(<= (support-margin ?a) 0.05)",
    "over-body": "(over-body ?a ?b 0.01)",
    "over-support": "(over-support ?a ?b 0.3)",
    "support-gap": "(<= (support-gap ?a ?b) 0.01)",
    "rests-on": "(rests-on ?a ?b 0.07)",
    "aligned": "(aligned (z-axis ?a) (x-axis ?b) 0.1)",
    "z-aligned": "(z-aligned ?a ?b 0.1)",
    "upright": "(upright ?a 0.05)",
    "x-horizontal": "(x-horizontal ?a 0.05)",
}


def test_stdlib_modules_are_listed_and_check_clean():
    mods = stdlib_modules()
    assert "tmpc/geometry" in mods
    ws = Workspace()
    for m in mods:
        parsed = ws.load_stdlib(m.split("/", 1)[1], None)
        report = check_parsed(ws, [parsed])
        assert report.ok and not report.diagnostics, report.diagnostics


def test_every_geometry_helper_has_a_use():
    ws = Workspace()
    module = ws.load_stdlib("geometry", None).definitions[0]
    assert {d.name.text for d in module.defines} == set(GEOMETRY_USES)


@pytest.mark.parametrize("name", sorted(GEOMETRY_USES))
def test_geometry_helper_in_a_predicate(name):
    text = f"""(define (domain g) (:requirements :typing :tmpc) (:types thing)
  (:include "tmpc/geometry")
  (:predicates (holds ?a - thing ?b - thing :semantics {GEOMETRY_USES[name]})))"""
    rep = check(text)
    assert rep.ok and not rep.diagnostics, rep.diagnostics
