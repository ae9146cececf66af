"""flyby_planner: the capture methods, one subpackage each, and PlannerCore with its node.

* ``flyby``: the fly-by (Matsumoto et al., seed 000): grasp search, keep-out, passive safety, the plan search.
* ``optimal``: the optimization-based approach (Jacobsen et al., seed 003).
* ``sync``: the synchronized approach to a fast-spinning target (Seweryn and Banaszkiewicz, seed 001).
* ``transport``: the transport of the captured body (Matsunaga et al., seed 004).
* ``transfer``: the terminal transfer's two CW impulses (seed 000 eq 28-29), shared by the fly-by, the transport
  plan and guidance.
* ``methods``: each method behind one protocol for the mission's planner, and the choice among them (``auto``).
* ``params``: PlannerParams, the planner's parameter record of a scenario, one sub-record per method.
* ``planner_core`` / ``planner_node``: the planner of the mission and its ROS node; ``plan_outputs``: what it
  publishes.
"""
