"""The validator's report: violations (each naming a state, or a motion between two) and a
summary, as text or JSON (:mod:`tmpc.runtime.validate.core`)."""

from __future__ import annotations

from dataclasses import dataclass, field

#: the text report lists at most this many violations
SHOW = 20


@dataclass
class Violation:
    state: int | None             # None: the plan as a whole
    kind: str                     # initial bounds joint base object collision motion held
    message: str                  # mode action precondition configuration goal actions
    to: int | None = None
    details: dict = field(default_factory=dict)

    def text(self) -> str:
        if self.kind == "goal":
            return self.message
        if self.state is None:
            return self.message
        where = f"state {self.state}" + (f" -> {self.to}" if self.to is not None else "")
        return f"{where}: {self.message}"

    def as_json(self) -> dict:
        return {"state": self.state, "to": self.to, "kind": self.kind, "message": self.text(),
                **self.details}


@dataclass
class Report:
    states: int
    actions: int
    motion_checks: int = 0
    violations: list[Violation] = field(default_factory=list)
    #: W830: released objects that do not rest on a support (violations with --strict)
    warnings: list[Violation] = field(default_factory=list)
    seconds: float = 0.0
    tolerance: float = 0.0
    resolution: float = 0.0
    kinematics: str = ""
    status: str | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def valid(self) -> bool:
        return not self.violations

    def summary(self) -> str:
        counts = (f"{self.states} state{'s' if self.states != 1 else ''}, {self.actions} "
                  f"action{'s' if self.actions != 1 else ''}, {self.motion_checks} motion checks")
        if self.valid:
            return f"valid: {counts}"
        n = len(self.violations)
        return f"invalid: {n} violation{'s' if n != 1 else ''} ({counts})"

    def text(self) -> str:
        lines = [self.summary()]
        lines += [f"  {v.text()}" for v in self.violations[:SHOW]]
        if len(self.violations) > SHOW:
            lines.append(f"  ... and {len(self.violations) - SHOW} more (--json lists all)")
        lines += [f"warning[W830]: {w.text()}" for w in self.warnings[:SHOW]]
        if len(self.warnings) > SHOW:
            lines.append(f"  ... and {len(self.warnings) - SHOW} more warnings (--json lists all)")
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)

    def as_json(self) -> dict:
        return {"valid": self.valid, "states": self.states, "actions": self.actions,
                "motion_checks": self.motion_checks, "tolerance": self.tolerance,
                "resolution": self.resolution, "kinematics": self.kinematics,
                "status": self.status, "seconds": round(self.seconds, 3), "notes": self.notes,
                "violations": [v.as_json() for v in self.violations],
                "warnings": [{"code": "W830", **w.as_json()} for w in self.warnings]}
