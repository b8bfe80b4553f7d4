"""Source files and spans.

Every position tmpc shows a user comes from a :class:`Span` into a :class:`SourceFile`.
Spans store 0-based character offsets; lines and columns are derived on demand.
User-facing text uses 1-based lines and columns (``PATH:LINE:COL``); the language server uses
0-based ones. :meth:`SourceFile.lsp_position` is the one place that converts.
"""

from __future__ import annotations

import bisect
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
    _line_starts: list[int] = field(default_factory=list, repr=False)

    def __post_init__(self) -> None:
        starts = [0]
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
        """0-based (line, character) for the language server protocol."""
        line, col = self.line_col(offset)
        return line - 1, col - 1

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
