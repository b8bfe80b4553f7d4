"""Helpers for the tests that drive `tmpc lsp` through pytest-lsp's client."""

from __future__ import annotations

import asyncio
import time
from pathlib import Path

from lsprotocol import types as T
from pytest_lsp import LanguageClient


class _Published(dict):
    """``client.diagnostics`` (uri -> the last diagnostics published) that also counts the
    publishes per uri."""

    def __init__(self, *args):
        super().__init__(*args)
        self.count: dict[str, int] = {}

    def __setitem__(self, uri, diagnostics):
        super().__setitem__(uri, diagnostics)
        self.count[uri] = self.count.get(uri, 0) + 1


def mark(client: LanguageClient, uri: str) -> int:
    """How many times diagnostics were published for ``uri`` so far (take it before an edit)."""
    if not isinstance(client.diagnostics, _Published):
        client.diagnostics = _Published(client.diagnostics)
    return client.diagnostics.count.get(uri, 0)


async def published(client: LanguageClient, uri: str, before: int, timeout: float = 60.0):
    """Wait for a publish for ``uri`` after ``before`` (:func:`mark`), and return the
    diagnostics. Polling the count is race-free, where waiting on pytest-lsp's one notification
    future can miss a publish that follows another file's in the same burst."""
    end = time.monotonic() + timeout
    while mark(client, uri) <= before:
        if time.monotonic() > end:
            raise TimeoutError(f"no diagnostics published for {uri} within {timeout:g} s")
        await asyncio.sleep(0.005)
    return client.diagnostics[uri]


async def open_document(client: LanguageClient, path: Path, text: str | None = None) -> str:
    """Open ``path`` (with ``text``, else its contents) and wait for its diagnostics."""
    uri = path.as_uri()
    before = mark(client, uri)
    client.text_document_did_open(T.DidOpenTextDocumentParams(text_document=T.TextDocumentItem(
        uri=uri, language_id="pddl", version=1,
        text=text if text is not None else path.read_text())))
    await published(client, uri, before)
    return uri
