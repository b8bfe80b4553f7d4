"""Helpers for the tests that drive `tmpc lsp` through pytest-lsp's client."""

from __future__ import annotations

from pathlib import Path

from lsprotocol import types as T
from pytest_lsp import LanguageClient


async def published(client: LanguageClient, uri: str):
    """The next diagnostics published for ``uri`` (a check publishes for every open file it
    read, and an earlier test's debounced check may still be on its way)."""
    while True:
        params = await client.wait_for_notification(T.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
        if params.uri == uri:
            return params


async def open_document(client: LanguageClient, path: Path, text: str | None = None) -> str:
    """Open ``path`` (with ``text``, else its contents) and wait for its diagnostics."""
    uri = path.as_uri()
    client.text_document_did_open(T.DidOpenTextDocumentParams(text_document=T.TextDocumentItem(
        uri=uri, language_id="pddl", version=1,
        text=text if text is not None else path.read_text())))
    await published(client, uri)
    return uri
