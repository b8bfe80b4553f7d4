"""Source files and spans.

Every position tmpc shows a user comes from a :class:`Span` into a :class:`SourceFile`.
Spans store 0-based character offsets; lines and columns are derived on demand.
User-facing text uses 1-based lines and columns (``PATH:LINE:COL``); the language server uses
0-based ones counted in UTF-16 code units: :meth:`SourceFile.lsp_position` and
:meth:`SourceFile.lsp_offset` are the one place that converts.
"""

from __future__ import annotations

import bisect
from array import array
from dataclasses import dataclass, field
from pathlib import Path


@dataclass(frozen=True, slots=True)
class Span:
    """Half-open character range ``[start, end)`` in the file named ``path``."""

    path: str
    start: int
    end: int

    def cover(self, other: "Span") -> "Span":
        """Smallest span containing both (same file)."""
        return Span(self.path, min(self.start, other.start), max(self.end, other.end))


@dataclass(eq=False)
class SourceFile:
    """The text of one input file plus a line index."""

    path: str
    text: str
    #: offsets where lines start, as machine integers (a list of ints costs 36 bytes a line)
    _line_starts: array = field(default_factory=lambda: array("q"), repr=False)

    def __post_init__(self) -> None:
        starts = array("I" if len(self.text) < 2 ** 32 else "q", [0])
        find = self.text.find
        i = find("\n")
        while i != -1:
            starts.append(i + 1)
            i = find("\n", i + 1)
        self._line_starts = starts

    @classmethod
    def read(cls, path: str | Path) -> "SourceFile":
        """Read a UTF-8 file (BOM and CRLF tolerated). Raises OSError/UnicodeDecodeError."""
        data = Path(path).read_bytes()
        text = data.decode("utf-8-sig")
        return cls(str(path), text)

    @classmethod
    def undecodable(cls, path: str | Path, exc: UnicodeDecodeError) -> tuple["Span", "SourceFile"]:
        """Where a file that is not UTF-8 first fails to decode, as a span over the file decoded
        with replacement characters (so E011 can point at line:col)."""
        data = Path(path).read_bytes()
        text = data.decode("utf-8-sig", errors="replace")
        at = len(data[:exc.start].decode("utf-8-sig", errors="replace"))
        return Span(str(path), at, at + 1), cls(str(path), text)

    @property
    def line_count(self) -> int:
        return len(self._line_starts)

    def line_col(self, offset: int) -> tuple[int, int]:
        """1-based (line, column) of a character offset; columns count characters."""
        offset = max(0, min(offset, len(self.text)))
        line = bisect.bisect_right(self._line_starts, offset) - 1
        return line + 1, offset - self._line_starts[line] + 1

    def lsp_position(self, offset: int) -> tuple[int, int]:
        """0-based (line, character) for the language server protocol, where ``character``
        counts UTF-16 code units (LSP's default encoding): a character outside the Basic
        Multilingual Plane (an emoji in a comment) counts 2. The inverse is :meth:`lsp_offset`."""
        line, col = self.line_col(offset)
        start = self._line_starts[line - 1]
        return line - 1, _utf16_len(self.text[start:start + col - 1])

    def lsp_offset(self, line: int, character: int) -> int:
        """The character offset of a 0-based LSP (line, UTF-16 character) position, clamped to
        the line (a position past its end means its end, as the protocol says)."""
        if line >= self.line_count:
            return len(self.text)
        if line < 0:
            return 0
        start = self._line_starts[line]
        end = self._line_starts[line + 1] - 1 if line + 1 < self.line_count else len(self.text)
        units = 0
        for i in range(start, end):
            if units >= character:
                return i
            units += 2 if ord(self.text[i]) > 0xFFFF else 1
        return end

    def offset(self, line: int, col: int) -> int:
        """Inverse of :meth:`line_col` (1-based in)."""
        line = max(1, min(line, self.line_count))
        return min(self._line_starts[line - 1] + col - 1, len(self.text))

    def line_text(self, line: int) -> str:
        """Text of a 1-based line without its newline."""
        start = self._line_starts[line - 1]
        end = self._line_starts[line] - 1 if line < self.line_count else len(self.text)
        return self.text[start:end].rstrip("\r")

    def span(self, start: int, end: int) -> Span:
        return Span(self.path, start, end)


def _utf16_len(text: str) -> int:
    """Length of ``text`` in UTF-16 code units."""
    return len(text) + sum(1 for ch in text if ord(ch) > 0xFFFF)
