"""Loading a world for the commands: an input file (scene or run configuration) -> scene, robot
model, jitted forward kinematics, the checked program when the configuration names one, and
(lazily) the collision checker."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

from tmpc.lang.diagnostics import CheckError, InputError, SceneError, error
from tmpc.lang.scene import RunConfig, Scene


@dataclass(eq=False)
class World:
    scene: Scene
    config: RunConfig | None = None
    program: object | None = None            # CheckedProgram
    files: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    #: (path, manifest) when loaded from a compiled artifact
    artifact: tuple | None = None

    @cached_property
    def model(self):
        from tmpc.compiler.fk import build_robot_model
        from tmpc.lang.robot import load_urdf
        if self.scene.robot is None:
            return None
        # Kinematics needs no meshes: a checkout without them (tmit-star's repository) can still
        # be evaluated; `collision` insists on them.
        tree = load_urdf(self.scene.robot.urdf, Path(self.scene.path).parent, strict_meshes=False)
        return build_robot_model(tree, self.scene.robot, self.scene.bounds)

    @cached_property
    def fk(self):
        from tmpc.compiler.fk import make_fk
        from tmpc.compiler.jaxcfg import configured
        if self.model is None:
            return None
        return configured().jit(make_fk(self.model))

    def allowed_pairs(self) -> tuple[tuple[str, str], ...]:
        from tmpc.lang.scenes import load_allowed_pairs
        if self.config is not None and self.config.allowed_collisions is not None:
            return load_allowed_pairs(self.config.allowed_collisions)
        return ()

    def collision(self, tolerance: float = 0.0):
        from tmpc.compiler.fk import build_robot_model
        from tmpc.lang.robot import load_urdf
        from tmpc.runtime.collision import CollisionWorld
        model = self.model
        if model is not None:
            # every link mesh must be there to check collisions (E562 names a missing one)
            tree = load_urdf(self.scene.robot.urdf, Path(self.scene.path).parent)
            model = build_robot_model(tree, self.scene.robot, self.scene.bounds)
        return CollisionWorld(self.scene, model, fk=self.fk, tolerance=tolerance,
                              allowed=self.allowed_pairs())


def load_world(path: str | Path, with_program: bool = True) -> World:
    """A scene file (native/tmit-star JSON, planet XML) or a run configuration (TOML, tmit-star
    spec JSON). A configuration's domain and problem are checked too."""
    from tmpc.compiler.artifact import extract, is_artifact
    from tmpc.lang.configs import is_run_config, load_config
    from tmpc.lang.scenes import LoadReport, load_scene
    path = Path(path)
    if not path.exists():
        raise InputError(error("E010", f"no such file: {path}", None))
    if path.suffix.lower() in (".pddl", ".tmpc"):
        raise InputError(error(
            "E827", f"{path} is a PDDL file; this command needs a run configuration (or a "
            "scene) that names the domain, problem and scene", None,
            "write a manifest like examples/clutter/clutter.toml ([problem] domain, problem, "
            "scene), or give --domain/--problem/--scene to `tmpc compile`; for task planning "
            "alone: `tmpc plan DOMAIN PROBLEM`"))
    if is_artifact(path):
        manifest, run = extract(path)      # checked; the world then comes from the extraction
        world = load_world(run, with_program)
        world.artifact = (path, manifest)
        return world
    report = LoadReport()
    config = None
    # $TMPC_MESH_PATH also serves object meshes (tmit-star's repository lacks its .obj files)
    fallback = [d for d in os.environ.get("TMPC_MESH_PATH", "").split(os.pathsep) if d]
    if is_run_config(path):
        config = load_config(path, report=report)
        scene = load_scene(config.scene, mesh_dir=config.mesh_dir, report=report,
                           strict_meshes=False, mesh_fallback_dirs=fallback)
    else:
        scene = load_scene(path, report=report, mesh_fallback_dirs=fallback)
    world = World(scene, config, files=dict(report.files), warnings=list(report.warnings))
    if config is not None and with_program:
        from tmpc.lang.program import check_paths
        checked = check_paths([config.domain, config.problem])
        world.files.update(checked.workspace.files)
        if not checked.ok:
            raise CheckError([d for d in checked.diagnostics if d.is_error],
                             checked.workspace.files)
        world.program = checked.programs[0] if checked.programs else None
    return world


__all__ = ["World", "load_world", "SceneError"]
