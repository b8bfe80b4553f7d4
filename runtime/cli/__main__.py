"""`python -m tmpc.runtime.cli ...` is `tmpc ...`."""

import sys

from tmpc.runtime.cli.main import main

sys.exit(main())
