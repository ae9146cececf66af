"""Optimization-based approach planning, seed 003 section 4 (eq 3-7), and a convex solver of the same problem.

Pure numpy/scipy/cvxpy, no ROS. The modules:

* ``problem``: what is planned -- the chaser's state now, the target's motion and geometry, the end state
  synchronized with the grasp point at an offset (seed 000 eq 20-21), the chaser's limits, the eq 5 weights.
* ``cost``: the five metrics of seed 003 eq 5 (safety, actuator limit, fuel, plume impingement, time) and the
  robots' mutual safety, evaluated on any sampled trajectory.
* ``spline``: the parabolic-spline path through waypoints of seed 003 section 4.1 (eq 3).
* ``baseline``: the paper's method -- Nelder-Mead on eq 5 (eq 6-7), one waypoint more while the cost improves.
* ``scp``: sequential convex programming (cvxpy, Clarabel) on the Clohessy-Wiltshire dynamics, keep-out,
  plume and mutual separation as linearized constraints; the least delta-v bound of a time and acceleration.
* ``sampler``: a plan as time-stamped hill points (position, velocity, acceleration) for /planner/trajectory.

Frames and units as in flyby_planner.grasp: ``hill`` of flyby_sim.dynamics.orbital, velocities relative to the
rotating hill frame, SI units. Quaternions (x, y, z, w), scalar last.
"""
