"""The planner's parameter record (``PlannerParams``): what PlannerCore reads of a scenario, one sub-record per
capture method (flyby_msgs_py.params; the keys' defaults, ranges and descriptions are the scenario schema's).

* ``flyby``: the fly-by's PlannerConfig (flyby_planner.flyby.config), whose fields the core's prediction also reads
  (mean motion, target inertia, grasp point, boxes).
* ``optimal``: the optimization-based approach's ApproachSettings (flyby_planner.optimal.approach).
* ``sync``: the synchronized approach's SyncParams (flyby_planner.sync.approach).

Besides them: planner.method, the chaser's model, and the leaders of a ``chasers:`` scenario (the chasers that plan
before this one, with their envelope radii). No ROS here.
"""

from flyby_msgs_py import params
from flyby_planner.flyby.config import PlannerConfig
from flyby_planner.optimal.approach import ApproachSettings
from flyby_planner.sync.approach import SyncParams


def _leader_envelope_radius_m(scenario):
    """{name: envelope radius [m]} of the chasers that plan before this one, in the file's order (none for one
    chaser)."""
    names = scenario.chaser_names
    leaders = names[:names.index(scenario.chaser_name)] if names else ()
    return {name: scenario.for_chaser(name).chaser.envelope_radius_m for name in leaders}


@params.record
class PlannerParams:
    """PlannerCore's record (module doc)."""

    method: str = params.key('planner.method')
    chaser_model: str = params.key('chaser.model')
    leader_envelope_radius_m: dict = params.derived(_leader_envelope_radius_m)
    flyby: PlannerConfig = params.sub(PlannerConfig)
    optimal: ApproachSettings = params.sub(ApproachSettings)
    sync: SyncParams = params.sub(SyncParams)
