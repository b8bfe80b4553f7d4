"""Atomic writes (tmpc.lang.fileio) and the interrupt's clean-up of their temporary files."""

from __future__ import annotations

import pytest

from tmpc.lang import fileio


def test_an_atomic_write_replaces_the_file_and_leaves_no_temporary(tmp_path):
    path = tmp_path / "out.bin"
    fileio.atomic_write_bytes(path, b"one")
    fileio.atomic_write_bytes(path, b"two")
    assert path.read_bytes() == b"two"
    assert [p.name for p in tmp_path.iterdir()] == ["out.bin"]


def test_once_stopping_no_thread_makes_a_temporary_file(tmp_path, monkeypatch):
    """The interrupt removes the temporaries under way; a write another thread starts after
    that (a kernel export finishing) must not leave a new one between the clean-up and the
    exit (tests/e2e/test_signals.py saw a `.jaxexport.*.tmp` left so)."""
    monkeypatch.setattr(fileio, "_STOPPING", [False])
    monkeypatch.setattr(fileio, "_IN_FLIGHT", set())
    fileio.remove_in_flight()
    with pytest.raises(fileio.StoppingError):
        fileio.atomic_write_bytes(tmp_path / "late.bin", b"x")
    assert list(tmp_path.iterdir()) == []
