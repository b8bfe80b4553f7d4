"""tmpc.stdlib: predicates and helpers written in the tmpc DSL itself, loaded by `(:include "tmpc/NAME")`."""
