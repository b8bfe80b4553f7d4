"""tmpc.runtime: artifacts -> plans and repairs. Also hosts the CLI (the composition root).

Importing this package must stay cheap: heavy modules (JAX, Z3, OMPL) are imported lazily by the
commands that need them.
"""
