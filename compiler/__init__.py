"""tmpc.compiler: checked programs -> artifacts (grounding, IR, JAX/SMT/CPZ backends)."""
