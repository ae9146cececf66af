"""Optimization-based approach planning, seed 003 section 4 (eq 3-7), and a convex solver of the same problem:
Jacobsen, Matsumoto, Dubowsky et al., *Planning of safe kinematic trajectories for free-flying robots approaching an
uncontrolled spinning satellite* (seed 003).

Pure numpy/scipy/cvxpy, no ROS. The modules:

* ``problem``: what is planned -- the chaser's state now, the target's motion and geometry, the end state
  synchronized with the grasp point at an offset (seed 000 eq 20-21), the chaser's limits, the eq 5 weights.
* ``cost``: the five metrics of seed 003 eq 5 (safety, actuator limit, fuel, plume impingement, time) and the
  robots' mutual safety, evaluated on any sampled trajectory.
* ``spline``: the parabolic-spline path through waypoints of seed 003 section 4.1 (eq 3).
* ``baseline``: the paper's method -- Nelder-Mead on eq 5 (eq 6-7), one waypoint more while the cost improves.
* ``scp``: sequential convex programming (cvxpy, Clarabel) on the Clohessy-Wiltshire dynamics, keep-out,
  plume and mutual separation as linearized constraints; ``program``: the convex program of one iteration.
* ``delta_v_bound``: the least delta-v bound of a time and acceleration, whatever the path.
* ``mutual``: mutual safety against another robot's published plan (seed 003 section 4.2, Fig 12).
* ``approach``: the approach as the mission plans it (ApproachSettings, its parameter record of a scenario; SCP
  from the estimates, the check before flight).
* ``sampler``: a plan as time-stamped hill points (position, velocity, acceleration) for /planner/trajectory.

Frames and units as in flyby_planner.flyby.grasp_search: ``hill`` of flyby_sim.dynamics.orbital, velocities relative
to the rotating hill frame, SI units. Quaternions (x, y, z, w), scalar last.
"""
