"""tmpc.runtime.cli: the command line, one module per command; the composition root.

Importing it stays cheap: each command module imports its heavy dependencies when it runs.
"""

from tmpc.runtime.cli.main import main as main
from tmpc.runtime.cli.main import run_and_exit as run_and_exit
