"""flyby_planner: the capture methods: the fly-by (grasp search, keep-out, passive safety), the optimization-based
approach, the synchronized approach and the transport plan, and PlannerCore with its node."""
