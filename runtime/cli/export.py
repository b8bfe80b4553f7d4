"""`tmpc export PLAN --format ros-joint-trajectory [-o FILE]`: a timed plan as ROS
JointTrajectory-shaped documents (docs/robot-export.md); JSON or YAML by FILE's extension,
JSON on stdout without -o."""

from __future__ import annotations

import json
import sys

from tmpc.runtime.cli.exits import EXIT_OK
from tmpc.runtime.plans import read_plan
from tmpc.runtime.timing import ros_document, write_ros


def run_export(args) -> int:
    plan = read_plan(args.plan)            # the shape first (E800-E818)
    with open(args.plan, encoding="utf-8") as f:
        doc = json.load(f) if plan.form == "tmpc-plan/1" else {"states": []}
    document = ros_document(doc, str(args.plan))
    text = write_ros(document, args.output)
    if args.output:
        n = sum(step["type"] == "trajectory" for step in document["steps"])
        sys.stderr.write(f"wrote {args.output}: {n} trajectories, "
                         f"{document['duration']:.2f} s\n")
    else:
        sys.stdout.write(text)
    return EXIT_OK
