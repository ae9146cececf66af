"""The plant: chaser relative translation with finite burns, target attitude, sensors, events.

The chaser is a point mass (the default) or, when the configuration has a ``chaser_body``
(``RigidChaserConfig``, scenario ``chaser.model: rigid_body``), the six-degree-of-freedom chaser of
``flyby_sim.chaser_body``: attitude, reaction wheels, body-fixed thrusters, wrench and wheel commands and an
IMU (docs/chaser_6dof.md). The point-mass chaser's truth, measurements and events do not depend on anything
the rigid-body chaser adds.

After the capture (``capture``) the chaser is welded to the target where it is, unless the configuration has a
``grasp`` (scenario ``post_capture``, docs/post_capture.md; the rigid-body chaser): then the arm's
impedance joins the two free bodies (``dynamics.grasp.simulate_grasp``, from the first contact, in the inertial
frame that coincides with hill at the capture; the orbit is left out over the seconds of the grasp) until the
relative motion is damped and the arm locks (``grasp_damped``), or beyond the arm's limits lets go
(``grasp_released``: both fly on freely, the target off the hill origin). Once locked, chaser and target are one
rigid body (``dynamics.grasp.weld``: the true combined mass properties, the momentum both carried) whose CoM
moves by the relative orbital dynamics and whose thrusters act at their true positions about the combined CoM
(``chaser_body.SixDofChaser`` with ``com_body_m``); wrench and wheel commands stamped from one IMU period after the
lock on apply to it (earlier ones, from before the capture, are ignored). The target's truth then carries its CoM
off the hill origin (``TruthSample.r_target_hill``), and the IMU's accelerometer, at the chaser's CoM, reads the
combined body's rotation too (seed 004 section 2.2: F/(m + M) + omega_dot x p + omega x (omega x p)). A run that
starts attached (scenario ``post_capture.start: attached``, seed 004 section 3.1) is that combined body from t = 0
(event ``attached``), the target's CoM at X_s from the chaser's and turning with it; commands from one IMU period on.

Pure numpy/scipy, no ROS: the simulator node wraps it, Monte Carlo drives it directly.

Frames and conventions are those of ``flyby_sim.dynamics.orbital`` (hill, ECI) with quaternions (x, y, z, w),
scalar last. The target's attitude is integrated in ECI (q_eci_from_body, seed 000 eq 4) and
reported in hill: q_hill_from_body(t) = q_hill_from_eci(t) * q_eci_from_body(t), where the hill
axes turn by n t about ECI +z. ``omega_body`` is always the target's inertial angular velocity
in body axes.

Determinism: time advances as step_index * step_s; the chaser is integrated with fixed-step RK4 whose
steps are split at every burn start and end, so thrust timing is exact to the sim time; burns are
fixed by the command stamps (thrusters module); the attitude integrator is never restarted; every
random draw comes from seed-derived streams, one per consumer (thrusters, each sensor). Truth thus
depends only on the configuration and the commands (stamps, values, order), not on when before
its stamp a command arrived.

Cost: Monte Carlo steps the plant some 10^4 times a run, so the chaser is integrated on Python floats
(``rk4_step_floats``, the same arithmetic as the numpy RK4) and the target attitude, which the
commands never change, is evaluated ahead for a chunk of steps at a time (``AttitudePropagator.states_at``,
``q_hill_from_body_many``); both give the same numbers to the bit as one step at a time.

The modules: ``config`` (PlantConfig, GraspConfig, TruthSample, Measurement), ``core`` (``Plant``: state, commands,
the step, truth and sensors), ``point_mass`` (the point-mass chaser's finite burns), ``capture`` (from the capture
on: welded, grasp, combined body, released). The configuration of a validated scenario is
``PlantConfig.from_scenario(scenario)`` (a record, flyby_msgs_py.params).
"""

from flyby_sim.plant.config import DYNAMICS, GraspConfig, Measurement, PlantConfig, TruthSample
from flyby_sim.plant.core import ATTITUDE_CHUNK_STEPS, Plant

__all__ = ['ATTITUDE_CHUNK_STEPS', 'DYNAMICS', 'GraspConfig', 'Measurement', 'Plant', 'PlantConfig', 'TruthSample']
