"""tmpc.runtime.bench: planner x problem x seed (x parameter) sweeps, in one process or as tasks on
a backend (a local process pool, Ray), their statistics, tables, OMPL logs, results files, plots
and the performance document rendered from committed results files.
"""

from tmpc.runtime.bench.backends import BACKENDS as BACKENDS
from tmpc.runtime.bench.dispatch import Dispatch as Dispatch
from tmpc.runtime.bench.params import ParamError as ParamError
from tmpc.runtime.bench.params import parse_params as parse_params
from tmpc.runtime.bench.performance import ResultsError as ResultsError
from tmpc.runtime.bench.performance import render as render_performance  # noqa: F401 - the door's name
from tmpc.runtime.bench.report import write_report as write_report
from tmpc.runtime.bench.results import read_results as read_results
from tmpc.runtime.bench.sweep import Bench as Bench
from tmpc.runtime.bench.sweep import Stop as Stop
from tmpc.runtime.bench.sweep import check_output as check_output
from tmpc.runtime.bench.sweep import problem_names as problem_names
from tmpc.runtime.bench.worker import run_task as run_task
