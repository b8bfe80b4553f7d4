"""The warm-up's kernel loads (tmpc.runtime.problem._Loads): every call runs once, on the
background thread or on the caller's once it helps, and an error reaches the caller."""

from __future__ import annotations

import threading

import pytest

from tmpc.runtime.problem import _Loads


def test_each_load_runs_once_and_the_caller_takes_what_is_left():
    ran, started = [], threading.Event()
    lock = threading.Lock()

    def call(i):
        def run():
            if i == 0:                 # the background thread holds the first until the
                started.set()          # caller has taken one of its own
                assert helped.wait(10)
            with lock:
                ran.append((i, threading.current_thread().name))
            if threading.current_thread().name != "tmpc-warm-up":
                helped.set()
        return run

    helped = threading.Event()
    loads = _Loads([call(i) for i in range(5)])
    assert started.wait(10)
    seen = []
    loads.finish(seen.append)
    assert sorted(i for i, _ in ran) == list(range(5))
    assert {name for _, name in ran} == {"tmpc-warm-up", threading.current_thread().name}
    assert seen and seen == sorted(seen) and len(loads) == 5


def test_an_error_in_a_load_is_raised_by_finish():
    def bad():
        raise RuntimeError("no executable")

    loads = _Loads([bad, lambda: None])
    with pytest.raises(RuntimeError, match="no executable"):
        loads.finish()
