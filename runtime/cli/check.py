"""`tmpc check FILE... [--static]`: parse and check domains, problems, modules, scenes, run
configurations, URDFs and Lua files. Light by design: no grounding, JAX or Z3 unless ``--static``."""

from __future__ import annotations

import sys

from tmpc.lang.diagnostics import TmpcError
from tmpc.lang.lua import load_lua_predicates, lua_limits
from tmpc.lang.program import check_paths, config_program
from tmpc.runtime.cli.exits import EXIT_ERROR, EXIT_OK
from tmpc.runtime.cli.output import print_diagnostics, summary


def run_check(args) -> int:
    report = check_paths(args.files)
    if report.ok:
        report.diagnostics.extend(_traced_lua(report))
    if args.static and report.ok:
        # SAT/relaxation checks (W610-W613): opt-in, because they ground the problem and load
        # Z3, and plain `tmpc check` stays light enough for an editor on every keystroke; so
        # they are imported here, only for --static
        from tmpc.compiler.artifact import open_world
        from tmpc.compiler.smt import static_checks
        from tmpc.runtime.geo_checks import geometric_checks
        for prog in report.programs:
            report.diagnostics.extend(static_checks(prog, args.budget))
        if report.workspace.configs:
            # geometric conditions no configuration satisfies (W614), by projection
            for config in report.workspace.configs:
                report.diagnostics.extend(geometric_checks(open_world(config.path),
                                                           args.geometry_budget))
    if report.ok:
        report.diagnostics.extend(_setup_errors(report))
    print_diagnostics(report.diagnostics, report.workspace.files, args.format)
    if args.format != "json":
        counts = summary(report.diagnostics)
        names = ", ".join(_program_name(p) for p in report.programs)
        if report.ok:
            sys.stderr.write(f"ok: {names or 'no programs'}" + (f" ({counts})" if counts else "")
                             + "\n")
        else:
            sys.stderr.write(f"check failed: {counts}\n")
    return EXIT_OK if report.ok else EXIT_ERROR


def _traced_lua(report) -> list:
    """What tracing each run configuration's Lua predicates finds, as `run` and `compile` trace
    them before planning: a predicate that runs past the sandbox's limits (E704), reads an unknown
    field (E709), or falls back to direct evaluation (W700). The tracer is the compiler's (it
    imports numpy), so it is imported here, only when a configuration has Lua predicates."""
    out = []
    for config in report.workspace.configs:
        prog = config_program(config, report.programs)
        decls = {d.name.text: d for d in prog.domain.predicates if d.external} if prog else {}
        if not decls or config.semantics is None:
            continue
        from tmpc.compiler.lua_trace import trace_module
        try:
            module = load_lua_predicates(config.semantics, limits=lua_limits(config))
            result = trace_module(module, decls, strict=False)
        except TmpcError as exc:
            report.workspace.files.update(exc.files)
            out.extend(exc.diagnostics)
            continue
        report.workspace.files.update(module.files)
        out.extend(result.diagnostics)
    return out


def _setup_errors(report) -> list:
    """What `tmpc run`'s setup would reject in each run configuration (:mod:`tmpc.runtime.
    setup_checks`: unknown objects, missing support regions, static objects held, an unreachable
    goal, the start's limits and collisions), by grounding, the robot's kinematics and fcl; no
    kernel is compiled. The program is the one just checked (not parsed and checked again)."""
    out = []
    if not report.workspace.configs:
        return out
    from tmpc.lang.inputs import World
    from tmpc.lang.world import load_config_scene, mesh_search_dirs
    from tmpc.runtime.setup_checks import init_meanings, setup_diagnostics
    for config in report.workspace.configs:
        program = config_program(config, report.programs)
        if program is None:
            continue
        try:
            scene = load_config_scene(config, strict_meshes=False,
                                      mesh_fallback_dirs=mesh_search_dirs())
        except TmpcError as exc:
            report.workspace.files.update(exc.files)
            out.extend(exc.diagnostics)
            continue
        world = World(scene, config, program)
        out.extend(setup_diagnostics(world))
        out.extend(init_meanings(world))
    return out


def _program_name(p) -> str:
    name = f"domain {p.domain.name.text}" if p.domain.form == "domain" else \
        f"module {p.domain.name.text}"
    return name + (f" + problem {p.problem.name.text}" if p.problem else "")
