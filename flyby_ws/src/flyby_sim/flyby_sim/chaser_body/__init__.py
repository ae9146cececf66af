"""The plant's six-degree-of-freedom chaser: a rigid body with reaction wheels and body-fixed thrusters.

DESIGN §10, docs/chaser_6dof.md. Pure numpy/scipy, no ROS; ``flyby_sim.plant.Plant`` owns one when
its configuration has a ``chaser_body`` (scenario ``chaser.model: rigid_body``).

Frames and conventions are those of ``flyby_sim.dynamics.orbital``: quaternions (x, y, z, w), scalar last;
``q_a_from_b`` rotates b vectors into a. The attitude is integrated in ECI, q_eci_from_body (seed 000 eq 4, as
the target's), and reported in hill: q_hill_from_body(t) = q_hill_from_eci(t) * q_eci_from_body(t), the hill
axes turning by n t about ECI +z. ``omega_body`` is the chaser's inertial angular velocity in chaser_body axes,
h each wheel's axial angular momentum (``dynamics.rigid_body``).

Equations (constant inputs over each integration segment):

.. math::

    \\ddot r = a_{orbit}(r, \\dot r) + C_{hill\\,eci}(t) C_{eci\\,body}(q) F_b / m(t)   \\quad
        \\text{seed 000 eq 1-2 (seed 001 eq 2) with the thrust force}

    I \\dot\\omega = M_b - \\omega \\times (I \\omega + A h) - A u, \\quad \\dot h = u, \\quad
        \\dot q = \\tfrac12 q \\otimes (\\omega, 0)     \\quad \\text{seed 001 eq 3, seed 000 eq 4}

    \\dot m = -\\textstyle\\sum_i f_i / (I_{sp} g_0)

F_b, M_b: the firing thrusters' force and torque about the CoM in body axes (each thruster's own magnitude
factor and misalignment, ``actuators.draw_thruster_errors``, drawn once per run: they are properties of the
hardware); u: the wheel motor torques, limited as ``GyrostatPropagator`` does.

Integration: fixed-step classical RK4 on Python floats (``orbital.rk4_step_floats``). A plant step is cut at
every instant an input changes (a command's stamp, a burn's start and end, a wheel reaching its momentum
limit), so no discontinuity falls inside an RK4 step. Inside a segment the attitude takes
``rigid_body.substep_count`` substeps (no substep turns the body or its rate vector by more than
MAX_SUBSTEP_ANGLE_RAD, 0.01 rad: one substep per 0.05 s step below 11 deg/s). While no thruster
fires the translation does not depend on the attitude and is integrated as the point-mass chaser's is, one
RK4 step over the coast; while thrusters fire, translation, attitude, wheels and the hill impulse are
integrated together (the hill force turns with the body). The quaternion is renormalized at each step end.

Commands (time-tagged, zero-order hold, DESIGN §5 and §10) apply exactly from their stamp; one stamped before
the current time applies at once and is reported (``late_command``), never dropped. Thrusts: a wrench command
is allocated once (``actuators.allocate_wrench``, HiGHS, least fuel) and held; a thruster whose thrust would
give less than the minimum impulse bit over the hold the controller announces with the command (its control
period; one plant step if it announces none) stays off (``actuators.fire`` with that period); what the
thrusters cannot give (saturation and the minimum impulse bit) is reported once per command
(``wrench_undelivered``). An impulsive delta-v becomes a burn at the
attitude the chaser holds when it starts: its body direction is allocated a pure force of the point-mass
chaser's thrust (the navigation filter's burn model; the layout's largest if it gives less,
``actuators.plan_burn``, every firing thruster at least its minimum impulse bit over the burn, small burns
re-allocated for it) for the rocket equation's duration; a wrench held during a burn is added on top,
each thruster limited to its maximum (the burn first, ``wrench_limited_by_burn``).

The modules: ``config`` (RigidChaserConfig, ImuConfig), ``records`` (the accepted commands, a burn as started, a
step's totals), ``body`` (``SixDofChaser``: state, command queues, integration).
"""

from flyby_sim.chaser_body.body import SixDofChaser
from flyby_sim.chaser_body.config import MAX_SUBSTEP_ANGLE_RAD, ImuConfig, RigidChaserConfig
from flyby_sim.chaser_body.records import ManeuverRequest, StepTotals, ThrusterBurn, WheelCommand, WrenchCommand

__all__ = ['MAX_SUBSTEP_ANGLE_RAD', 'ImuConfig', 'ManeuverRequest', 'RigidChaserConfig', 'SixDofChaser', 'StepTotals',
           'ThrusterBurn', 'WheelCommand', 'WrenchCommand']
