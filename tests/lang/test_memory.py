"""Memory is linear in the input: `check` and `fmt` of a generated problem of a few hundred KB
stay under a small multiple of its size (traced allocations; issue L: a 50 MB problem took 3 GB).
Before the columns (sexpr.Packed, columns.py) the peaks were ~85x (check) and ~110x (fmt).
The large sizes, measured as process RSS, are in tests/bench/test_bench_memory.py."""

from __future__ import annotations

import tracemalloc

from tests.bench.gen import large_problem, logistics_domain
from tmpc.lang.program import check_paths
from tmpc.lang.source import SourceFile
from tmpc.runtime.cli.fmt import format_source

SIZE = 300_000


def _peak(fn) -> int:
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_check_and_fmt_peak_memory_is_a_small_multiple_of_the_input(tmp_path):
    (tmp_path / "domain.pddl").write_text(logistics_domain())
    text = large_problem(SIZE)
    (tmp_path / "problem.pddl").write_text(text)
    files = [tmp_path / "domain.pddl", tmp_path / "problem.pddl"]
    check_paths([files[0]])                       # imports and caches before measuring

    def check():
        assert check_paths(files).ok

    def fmt():
        out, errors = format_source(SourceFile.read(files[1]))
        assert out is not None and not errors

    check_ratio, fmt_ratio = _peak(check) / len(text), _peak(fmt) / len(text)
    assert check_ratio < 12, f"check: peak {check_ratio:.1f}x the input"
    assert fmt_ratio < 16, f"fmt: peak {fmt_ratio:.1f}x the input"
