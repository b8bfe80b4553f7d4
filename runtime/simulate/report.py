"""The report of a physics check: per released object its drift and tilt after settling,
unexpected contacts, the robot's tracking error, whether the goal still holds, the speed."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: a drift above this fails ``--strict`` (m)
DRIFT_LIMIT = 0.01
#: a released object tilted more than this after settling has tipped: it fails ``--strict``
#: (rad; the validator's W830 tilt, 5 degrees)
TILT_LIMIT = 0.0873


@dataclass
class SimReport:
    drift: dict[str, float] = field(default_factory=dict)
    tilt: dict[str, float] = field(default_factory=dict)
    contacts: list[dict] = field(default_factory=list)
    goal_holds: bool | None = None
    goal_failures: list[str] = field(default_factory=list)
    sim_seconds: float = 0.0
    wall_seconds: float = 0.0
    settled_poses: dict[str, list[float]] = field(default_factory=dict)
    #: per grasped object, how far it lay from the plan's pose when grasped (m): something
    #: moved it before its pick (the weld then pulls it to the plan's grasp)
    displaced: dict[str, float] = field(default_factory=dict)
    #: the largest |reference - actual| of each timed joint during the plan (rad or m)
    tracking: dict[str, float] = field(default_factory=dict)
    #: times MuJoCo found the simulation unstable (NaN or huge accelerations; it then resets
    #: the state): the replay says nothing about the plan, and fails
    unstable: int = 0
    #: samples of the motion: (t, {joint: value}, {object: 4x4 pose}), for ``--html``
    trace: list = field(default_factory=list, repr=False)

    @property
    def real_time_factor(self) -> float:
        return self.sim_seconds / self.wall_seconds if self.wall_seconds > 0 else float("inf")

    @property
    def max_drift(self) -> float:
        return max(self.drift.values(), default=0.0)

    @property
    def max_tracking(self) -> float:
        return max(self.tracking.values(), default=0.0)

    def ok(self) -> bool:
        return (not self.unstable and all(d <= DRIFT_LIMIT for d in self.drift.values())
                and all(d <= DRIFT_LIMIT for d in self.displaced.values())
                and all(a <= TILT_LIMIT for a in self.tilt.values())
                and self.goal_holds is not False)

    def as_json(self) -> dict:
        return {"ok": self.ok(), "drift": self.drift, "tilt": self.tilt,
                "contacts": self.contacts, "goal_holds": self.goal_holds,
                "goal_failures": self.goal_failures, "sim_seconds": self.sim_seconds,
                "wall_seconds": round(self.wall_seconds, 4),
                "real_time_factor": round(self.real_time_factor, 2),
                "displaced": self.displaced, "unstable": self.unstable,
                "tracking_error": {k: round(v, 6) for k, v in self.tracking.items()},
                "max_tracking_error": round(self.max_tracking, 6),
                "settled_poses": self.settled_poses}

    def text(self) -> str:
        lines = [f"{'ok' if self.ok() else 'FAILED'}: {len(self.drift)} released objects "
                 f"settled for the plan's {self.sim_seconds:.2f} s simulated in "
                 f"{self.wall_seconds:.2f} s ({self.real_time_factor:.1f}x real time)"]
        if self.unstable:
            lines.append(f"  the simulation was unstable ({self.unstable} times: MuJoCo reset it)")
        for name, d in sorted(self.drift.items()):
            flag = ("  (> 1 cm)" if d > DRIFT_LIMIT else "") + (
                "  (tipped: > 5 deg)" if self.tilt[name] > TILT_LIMIT else "")
            lines.append(f"  {name}: drift {1000 * d:.1f} mm, tilt "
                         f"{np.degrees(self.tilt[name]):.1f} deg{flag}")
        for name, d in sorted(self.displaced.items()):
            if d > DRIFT_LIMIT:
                lines.append(f"  {name}: {1000 * d:.1f} mm from the plan's pose when grasped "
                             "(moved before its pick)")
        if self.tracking:
            worst = max(self.tracking, key=self.tracking.get)
            lines.append(f"  tracking error at most {self.max_tracking:.2e} ({worst})")
        for c in self.contacts:
            lines.append(f"  contact {c['a']} - {c['b']} at {c['time']:.2f} s, "
                         f"{1000 * c['depth']:.1f} mm deep")
        if self.goal_holds is not None:
            lines.append(("  goal holds after settling" + (
                " (within 5 mm: " + "; ".join(self.goal_failures) + ")"
                if self.goal_failures else "")) if self.goal_holds else
                "  goal no longer holds: " + "; ".join(self.goal_failures))
        return "\n".join(lines)
