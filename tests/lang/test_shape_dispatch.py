"""The one shape dispatch (tmpc.lang.world.dispatch_shape): a table's case per shape kind, and a
miss that names the kind and the kinds the table has."""

from __future__ import annotations

import pytest

from tmpc.lang.world import SHAPE_KINDS, Shape, ShapeKindError, dispatch_shape


def test_a_shape_kind_without_a_case_names_it_and_the_cases():
    table = {"box": lambda s: "b", "sphere": lambda s: "s"}
    assert dispatch_shape(table, Shape("box", size=(1, 1, 1)), "a test")(None) == "b"
    assert dispatch_shape(table, "sphere", "a test")(None) == "s"
    with pytest.raises(ShapeKindError, match=r"a test: no case for shape kind `cylinder` "
                                             r"\(this table has box, sphere\)"):
        dispatch_shape(table, Shape("cylinder", radius=1.0, length=1.0), "a test")
    assert issubclass(ShapeKindError, ValueError)
    assert "mesh" in SHAPE_KINDS
