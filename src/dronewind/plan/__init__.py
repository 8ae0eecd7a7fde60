"""Plan a drone-mast validation campaign before flying it (``dronewind plan``).

* :mod:`~dronewind.plan.spec`: the plan file (site, conditions, platform, mast, targets);
* :mod:`~dronewind.plan.uncertainty`: predicted random uncertainties against hover duration;
* :mod:`~dronewind.plan.separation`: the drone-mast separation limit;
* :mod:`~dronewind.plan.power`: detection power of instrument errors;
* :mod:`~dronewind.plan.manifest`: the planned campaign as a virtual-campaign manifest;
* :mod:`~dronewind.plan.planner`: :func:`plan_campaign`, the answer;
* :mod:`~dronewind.plan.report`: the report page.
"""

from dronewind.plan.planner import CampaignPlan, plan_campaign
from dronewind.plan.spec import PlanSpec, load_plan, parse_plan

__all__ = ["CampaignPlan", "PlanSpec", "load_plan", "parse_plan", "plan_campaign"]
