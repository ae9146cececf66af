"""The transport planner's pure core: the combined body moved to a goal point on the reference orbit
with direction-limited thrusters, seed 004 §2.3 (orbit advance, Fig 4's "acrobatic" motion) and §3.2 (its
simulation and three rendezvous conditions): Matsunaga, Fukushima, Yamamoto and Ohkami, *TugRobot satellites for
in-orbit servicing* (seed 004).

Pure numpy/scipy, no ROS. The modules:

* ``model``: the combined body, its state, burns and plan, the settings, ``propagate`` (the planner's model, below)
  and the three conditions (``conditions_of``, ``missed_conditions``).
* ``thrusters``: the push axis (step 1) and the burn wrench of a torque (``torque_wrench``).
* ``slew``: the rest-to-rest slews (step 3) and guidance's re-solved slew (``resolve_slew``).
* ``plan``: ``plan_transport``, steps 2-5.

The two impulses' first guess is flyby_planner.transfer's CW transfer (seed 000 eq 28-29), the one the fly-by uses.

Frames and conventions. Body vectors are in ``chaser_body`` axes and from the chaser's CoM unless the name says
``com`` (the combined CoM, c from the chaser's). ``r_hill``, ``v_hill`` are the combined CoM's position and velocity
relative to the rotating hill frame (``flyby_sim.dynamics.orbital``). Quaternions are (x, y, z, w), scalar last;
the planner turns ``q_hill_from_body`` into ``q_eci_from_body`` (``orbital.q_eci_from_body``) and works in inertial
space, where a body at rest stays at rest (it turns in hill at n about hill -y). A burn's torque is about the
chaser's CoM (the ``/guidance/wrench`` contract); about the combined CoM it is T_com = T_chaser - c x F (seed 004
§2.2, ``combined_body`` module doc).

The planner's model (``propagate``): the combined CoM on the nonlinear relative dynamics (seed 000 eq 1,
``orbital.nonlinear_relative_accel_components``) with the burn's body force turned into hill by the attitude; the
rotation by Euler's equation about the combined CoM (``attitude.euler_rate``); gravity-gradient torque and the
fuel's mass left out (seed 004 §3.2 assumptions 2 and 4; its assumption 3, impulsive inputs, is replaced by finite
burns on the control grid). Classical RK4 (``orbital.rk4_step``), steps cut at every burn edge and limited to
``max_step_s`` and to ``max_step_angle_rad`` of rotation.

The rendezvous conditions of seed 004 §3.2, read as: (1) the angular momentum about the combined CoM below
0.1 kg m^2/s; (2) the CoM within 10 m of the goal; (3) "orbital momentum error below 0.01 N m s": the paper's unit
is garbled (N m s is an angular momentum); we read it as the linear momentum relative to the goal's circular motion,
m |v_hill| < 0.01 N s (the goal is fixed in hill).

The method (constructive, seed 004 §2.3's Fig 4 made systematic; the paper found its sequences by trial and error):

1. The push axis b: the body axis (of +-x, +-y, +-z) along which the allowed thrusters give the largest pure force
   about the combined CoM (``actuators.allocate_max_force`` on the layout moved to the combined CoM: max s with
   B_F f = s b, B_T f = 0, 0 <= f <= f_max). Every push is along b and turns nothing.
2. A two-impulse transfer: the CW solution (seed 000 eq 22) gives the first guess of the two impulses (hill), the
   first push's time searched for the least total delta-v (away from CW's singular transfer times), the second
   push ending at the arrival time.
3. Before each push a rest-to-rest slew aims b along the push's direction (inertial, at the push's middle): a spin-up
   burn, a torque-free coast, a spin-down burn; their body torques (six numbers) are found by Newton shooting on
   Euler's equation so that the rate is zero and b points along the push at the slew's end (roll about b left
   free: the least-norm Newton step). The burns are made long enough that each torque needs no more side force
   per unit than the least the thrusters allow along it (a pure torque where one exists), and each is allocated
   with the least side force (a linear program); a layout without a pure torque (the default less its -x pair has
   none about z) pushes the body while it turns.
4. Newton on the two impulses (six numbers, hill) against the full propagation of the whole sequence (slews' side
   forces, finite pushes, hill's turn during a push, the nonlinear dynamics), with the CW Jacobian of the impulses
   at the pushes' middles and Broyden's update (an out-of-plane aim turns the body about z, whose torque pushes).
   A schedule that does not hold (a push or a torque beyond the thrusters) is lengthened and planned again.
5. The three conditions checked on ``propagate``'s end state; ``TransportRefused`` names the bound otherwise.
"""
