"""`python -m tmpc.runtime.cli ...` is `tmpc ...`."""

from tmpc.runtime.cli.main import run_and_exit

run_and_exit()
