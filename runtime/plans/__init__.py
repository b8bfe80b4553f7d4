"""tmpc.runtime.plans: plan files (``tmpc-plan/1``) read and written, and the legacy state arrays.
"""

from tmpc.runtime.plans.read import Plan as Plan
from tmpc.runtime.plans.read import PlanState as PlanState
from tmpc.runtime.plans.read import check_plan_fits as check_plan_fits
from tmpc.runtime.plans.read import parse_ground as parse_ground
from tmpc.runtime.plans.read import parse_plan as parse_plan
from tmpc.runtime.plans.read import pose_matrix as pose_matrix
from tmpc.runtime.plans.read import read_plan as read_plan
from tmpc.runtime.plans.write import action_text as action_text
from tmpc.runtime.plans.write import file_digest as file_digest
from tmpc.runtime.plans.write import legacy_states as legacy_states
from tmpc.runtime.plans.write import plan_document as plan_document
from tmpc.runtime.plans.write import write_json_atomic as write_json_atomic
