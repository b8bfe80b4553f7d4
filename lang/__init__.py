"""tmpc.lang: every input -> checked, position-carrying models.

Never imports JAX, Z3, OMPL or lupa at module import time (the CLI's `check` and the language
server must start fast).
"""

from .diagnostics import CheckError as CheckError
from .diagnostics import Diagnostic as Diagnostic
from .diagnostics import InputError as InputError
from .diagnostics import ParseError as ParseError
from .diagnostics import Severity as Severity
from .diagnostics import TmpcError as TmpcError
from .reader import ParsedFile as ParsedFile
from .reader import parse_source as parse_source
from .reader import parse_text as parse_text
from .source import SourceFile as SourceFile
from .source import Span as Span
