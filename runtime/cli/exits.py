"""Exit codes of every command, in one place (docs/design.md §8)."""

EXIT_OK = 0
#: a user error, reported with diagnostics; also: a plan that is not valid
EXIT_ERROR = 1
EXIT_USAGE = 2
#: no plan, sample or state within the limits (a partial plan may have been written)
EXIT_NOT_FOUND = 3
#: an internal error: a bug (rerun with --debug and report it)
EXIT_INTERNAL = 70
#: interrupted by Ctrl-C (128 + SIGINT)
EXIT_INTERRUPTED = 130
