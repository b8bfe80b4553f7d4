"""tmpc.runtime.repair: abstraction repair (thesis ch. 3; docs/repair.md).

``tmpc repair`` finds observations of an action's executions that contradict its model, edits
the geometric precondition (a formula over the templates of ``stdlib/templates.tmpc``, whose
sets are constrained polynomial zonotopes) until it explains them, and writes it back as DSL.
"""

from tmpc.runtime.repair.domain import Target as Target
from tmpc.runtime.repair.domain import diff as diff
from tmpc.runtime.repair.domain import parse_truth as parse_truth
from tmpc.runtime.repair.domain import rewrite as rewrite
from tmpc.runtime.repair.domain import target as target
from tmpc.runtime.repair.experiments import EXPERIMENTS as EXPERIMENTS
from tmpc.runtime.repair.experiments import manifest_path as manifest_path
from tmpc.runtime.repair.experiments import run_experiment as run_experiment
from tmpc.runtime.repair.experiments import truth_text as truth_text
from tmpc.runtime.repair.loop import LoopConfig as LoopConfig
from tmpc.runtime.repair.loop import LoopResult as LoopResult
from tmpc.runtime.repair.loop import Recorded as Recorded
from tmpc.runtime.repair.loop import Sampled as Sampled
from tmpc.runtime.repair.loop import run_loop as run_loop
from tmpc.runtime.repair.model import TEMPLATES as TEMPLATES
from tmpc.runtime.repair.model import Formula as Formula
from tmpc.runtime.repair.report import edits_figure as edits_figure
from tmpc.runtime.repair.report import repair_table as repair_table
from tmpc.runtime.repair.report import write_report as write_report
from tmpc.runtime.repair.store import Store as Store
from tmpc.runtime.repair.world import PyController as PyController
from tmpc.runtime.repair.world import RepairWorld as RepairWorld
from tmpc.runtime.repair.world import SimController as SimController
