"""tmpc.lang: every input -> checked, position-carrying models.

Never imports JAX, Z3, OMPL or lupa at module import time (the CLI's `check` and the language
server must start fast).
"""

from tmpc.lang.diagnostics import CheckError as CheckError
from tmpc.lang.diagnostics import Diagnostic as Diagnostic
from tmpc.lang.diagnostics import InputError as InputError
from tmpc.lang.diagnostics import ParseError as ParseError
from tmpc.lang.diagnostics import Severity as Severity
from tmpc.lang.diagnostics import TmpcError as TmpcError
from tmpc.lang.reader import ParsedFile as ParsedFile
from tmpc.lang.reader import parse_source as parse_source
from tmpc.lang.reader import parse_text as parse_text
from tmpc.lang.source import SourceFile as SourceFile
from tmpc.lang.source import Span as Span
