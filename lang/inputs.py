"""An input file loaded and checked: :class:`World` = the scene, the run configuration (if the
input is one) and its checked program. The compiler turns it into a
:class:`~tmpc.compiler.compile.CompiledProgram` (``compile_world``); a compiled artifact is opened
by ``tmpc.compiler.artifact.open_world``, which extracts it and loads the extraction here."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

from tmpc.lang.diagnostics import CheckError, InputError, SceneError, error
from tmpc.lang.program import check_paths
from tmpc.lang.semantics_module import HAND_TYPE
from tmpc.lang.world import (
    LoadReport,
    RunConfig,
    Scene,
    hand_chain,
    is_run_config,
    load_allowed_pairs,
    load_config,
    load_config_scene,
    load_scene,
    load_urdf,
    mesh_search_dirs,
)


@dataclass(eq=False)
class World:
    """What an input describes. ``program`` is the :class:`~tmpc.lang.checker.CheckedProgram` of
    the configuration's domain and problem (None for a bare scene, or when not asked for)."""

    scene: Scene
    config: RunConfig | None = None
    program: object | None = None            # CheckedProgram
    files: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    #: (path, manifest) when loaded from a compiled artifact
    artifact: tuple | None = None

    def allowed_pairs(self) -> tuple[tuple[str, str], ...]:
        if self.config is not None and self.config.allowed_collisions is not None:
            return load_allowed_pairs(self.config.allowed_collisions)
        return ()


def load_world(path: str | Path, with_program: bool = True) -> World:
    """A scene file (native/tmit-star JSON, planet XML) or a run configuration (TOML, tmit-star
    spec JSON). A configuration's domain and problem are checked too. Compiled artifacts are the
    compiler's to open (``tmpc.compiler.artifact.open_world``)."""
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
    report = LoadReport()
    config = None
    # $TMPC_MESH_PATH also serves object meshes (tmit-star's repository lacks its .obj files)
    fallback = mesh_search_dirs()
    if is_run_config(path):
        config = load_config(path, report=report)
        scene = load_config_scene(config, report=report, strict_meshes=False,
                                  mesh_fallback_dirs=fallback)
    else:
        scene = load_scene(path, report=report, mesh_fallback_dirs=fallback)
    world = World(scene, config, files=dict(report.files), warnings=list(report.warnings))
    if config is not None and with_program:
        sem = {str(Path(config.problem).resolve()): config.module} if config.module else None
        checked = check_paths([config.domain, config.problem], semantics=sem)
        world.files.update(checked.workspace.files)
        if not checked.ok:
            raise CheckError([d for d in checked.diagnostics if d.is_error],
                             checked.workspace.files)
        world.program = checked.programs[0] if checked.programs else None
        world.scene = _hand_arm(world.scene, world.program)
    return world


def _hand_arm(scene: Scene, program) -> Scene:
    """A semantics module's hands (its ``tmpc-hand`` constants) move their arms: when the scene
    names no controllable joints, they are the joints from the robot's root to each hand (a PR2
    with one hand then plans with that arm and its torso, not with both arms and its head)."""
    robot = scene.robot
    if program is None or robot is None or robot.controllable is not None:
        return scene
    hands = [c.name.text for c in program.domain.constants
             if c.type is not None and any(n.key == HAND_TYPE for n in c.type.names)]
    if not hands:
        return scene
    tree = load_urdf(robot.urdf, strict_meshes=False)
    chain = tuple(dict.fromkeys(j for h in hands for j in hand_chain(tree, h)))
    if not chain:
        return scene
    return replace(scene, robot=replace(robot, controllable=chain))


__all__ = ["World", "load_world", "SceneError"]
