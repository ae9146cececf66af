"""The truth a run's figures are computed from (DESIGN §7, §10): the records of the simulator's truth topics as the
summary reads them (``flyby_mission.summary``), from a bag or from the headless driver's plant samples, and the fuel
of each truth step."""

from typing import NamedTuple

import numpy as np

from flyby_msgs_py import contract as c
from flyby_sim.dynamics.constants import STANDARD_GRAVITY_M_S2
from flyby_sim.dynamics.rotation import quat_rotate_many

TRUTH_TOPICS = [c.CLOCK, c.SIM_CHASER_ODOM, c.SIM_TARGET_ODOM, c.SIM_CHASER_THRUST, c.MISSION_PHASE, c.MISSION_EVENTS]
# The six-degree-of-freedom chaser's, besides.
RIGID_TRUTH_TOPICS = [c.SIM_CHASER_THRUSTERS]


class ChaserTruth(NamedTuple):
    """Truth of the chaser (the fields of /sim/chaser/odom the summary reads): t (N,) [s], position (N, 3)
    [m] and linear (N, 3) [m/s] in hill; the six-degree-of-freedom chaser's orientation_xyzw (N, 4),
    q_hill_from_chaser_body (None: a point mass), and angular (N, 3), its inertial rate in chaser_body axes
    [rad/s] (None where not read)."""

    t: np.ndarray
    position: np.ndarray
    linear: np.ndarray
    orientation_xyzw: np.ndarray = None
    angular: np.ndarray = None


class TargetTruth(NamedTuple):
    """Truth of the target (/sim/target/odom): t (N,), orientation_xyzw (N, 4) q_hill_from_body, angular
    (N, 3) inertial body rate in body axes [rad/s]; its CoM's position (N, 3) [m] in hill and velocity linear
    (N, 3) [m/s] in target_body axes (off the hill origin after a grasp; None where not read)."""

    t: np.ndarray
    orientation_xyzw: np.ndarray
    angular: np.ndarray
    position: np.ndarray = None
    linear: np.ndarray = None


class ThrustTruth(NamedTuple):
    """Applied thrust (/sim/chaser/thrust): t (N,), force (N, 3) [N] in hill, the mean over the step ending at t;
    the six-degree-of-freedom chaser's torque (N, 3) [N m] about its CoM (/sim/chaser/thrust) and each
    thruster's mean thrust thrusters (N, M) [N] (/sim/chaser/thrusters) on the same stamps (None: a point mass)."""

    t: np.ndarray
    force: np.ndarray
    torque: np.ndarray = None
    thrusters: np.ndarray = None


class WheelTruth(NamedTuple):
    """The reaction wheels' truth (/sim/chaser/wheels): t (N,), velocity (N, M), each wheel's speed relative to the
    body [rad/s]."""

    t: np.ndarray
    velocity: np.ndarray


def chaser_truth_from_odometry(odom):
    """The six-degree-of-freedom chaser's ChaserTruth from its /sim/chaser/odom series, whose twist is in
    chaser_body axes (nav_msgs' rule, DESIGN §10): the velocity turned into hill by the orientation."""
    return ChaserTruth(odom.t, odom.position, quat_rotate_many(odom.orientation_xyzw, odom.linear),
                       odom.orientation_xyzw, odom.angular)


def fuel_steps(thrust, scenario):
    """The fuel [kg] of each truth step of the thrust (the step ending at thrust.t[1:]; each thruster's impulse for
    the rigid body, the net force's for the point mass)."""
    dt = np.diff(thrust.t)
    each = (np.sum(thrust.thrusters[1:], axis=1) if thrust.thrusters is not None
            else np.linalg.norm(thrust.force[1:], axis=1))
    return each * dt / (scenario.chaser.thrusters.isp_s * STANDARD_GRAVITY_M_S2)


def thrust_truth(wrench, thrusters=None):
    """The ThrustTruth of a bag's /sim/chaser/thrust series and, for the six-degree-of-freedom chaser, its
    /sim/chaser/thrusters series (published together each step; a bag cut short may end one message apart: both are
    cut to the shorter); None without thrust. ValueError if the two have different stamps."""
    if thrusters is None:
        return None if wrench is None else ThrustTruth(wrench.t, wrench.force)
    n = min(len(wrench.t), len(thrusters.t))
    if not np.array_equal(thrusters.t[:n], wrench.t[:n]):
        raise ValueError('/sim/chaser/thrusters and /sim/chaser/thrust have different stamps')
    return ThrustTruth(wrench.t[:n], wrench.force[:n], wrench.torque[:n], thrusters.effort[:n])
