"""XML with positions: a small element tree over expat whose nodes carry spans (planet scenes)."""

from __future__ import annotations

from dataclasses import dataclass, field

from tmpc.lang.diagnostics import SceneError, error
from tmpc.lang.source import SourceFile, Span
from tmpc.lang.world.reader import LoadReport, display_name


@dataclass(eq=False)
class XmlNode:
    tag: str
    attrib: dict[str, str]
    start: int                       # offset of `<`
    tag_end: int = 0                 # offset just past the start tag's `>`
    text: str = ""                   # stripped character data directly inside
    content: tuple[int, int] | None = None   # span of that text in the file
    children: list["XmlNode"] = field(default_factory=list)
    parent: "XmlNode | None" = None

    @property
    def path(self) -> str:
        """XPath-like location for messages: ``/problem/objects/obj[3]/pose``."""
        if self.parent is None:
            return "/" + self.tag
        same = [c for c in self.parent.children if c.tag == self.tag]
        index = f"[{same.index(self) + 1}]" if len(same) > 1 else ""
        return f"{self.parent.path}/{self.tag}{index}"

    def child(self, tag: str) -> "XmlNode | None":
        return next((c for c in self.children if c.tag == tag), None)

    def all(self, tag: str) -> list["XmlNode"]:
        return [c for c in self.children if c.tag == tag]


def parse_xml(source: SourceFile, report: LoadReport, code: str = "E501") -> XmlNode:
    """Parse XML keeping each element's position. Malformed XML is SceneError ``code``."""
    from xml.parsers import expat

    text = source.text
    data = text.encode("utf-8")
    ascii_only = len(data) == len(text)

    cursor = [0, 0]     # (byte, char) of the last conversion: expat's indices only grow

    def char_offset(byte_index: int) -> int:
        if ascii_only:
            return byte_index
        b, c = cursor if byte_index >= cursor[0] else (0, 0)
        c += len(data[b:byte_index].decode("utf-8", "replace"))
        cursor[:] = [byte_index, c]
        return c

    parser = expat.ParserCreate()
    stack: list[XmlNode] = []
    chunks: list[list[str]] = []
    roots: list[XmlNode] = []

    def start(tag: str, attrib: dict[str, str]) -> None:
        pos = char_offset(parser.CurrentByteIndex)
        node = XmlNode(tag, attrib, pos)
        node.tag_end = text.find(">", pos) + 1 or pos + 1
        if stack:
            node.parent = stack[-1]
            stack[-1].children.append(node)
        else:
            roots.append(node)
        stack.append(node)
        chunks.append([])

    def chars(s: str) -> None:
        chunks[-1].append(s)

    def end(tag: str) -> None:
        node = stack.pop()
        node.text = "".join(chunks.pop()).strip()
        if node.text and not node.children:
            end_pos = char_offset(parser.CurrentByteIndex)
            raw = text[node.tag_end:end_pos]
            lead = len(raw) - len(raw.lstrip())
            node.content = (node.tag_end + lead, node.tag_end + len(raw.rstrip()))

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = chars
    try:
        parser.Parse(data, True)
    except expat.ExpatError as exc:
        line = exc.lineno or 1
        pos = source.offset(line, (exc.offset or 0) + 1)
        back = text.rfind("<", max(0, pos - 2), pos + 1)   # expat may point past `</`
        pos = back if back != -1 else pos
        raise SceneError(error(
            code, f"{display_name(source.path)}: malformed XML: "
            f"{expat.errors.messages.get(exc.code, str(exc))}", Span(source.path, pos, pos + 1),
            "check that every <tag> has its </tag> and that & is written &amp;"),
            {**report.files, source.path: source}) from None
    return roots[0]
