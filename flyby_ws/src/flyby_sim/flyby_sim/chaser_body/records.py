"""What the rigid-body chaser accepted and did: wrench, wheel and delta-v commands as accepted, a burn as started,
the means over a step."""

from typing import NamedTuple

import numpy as np


class WrenchCommand(NamedTuple):
    """A commanded body wrench as accepted: the nominal thrusts it holds and what they cannot give."""

    seq: int  # command number, counting wrench commands from 0
    t_stamp: float
    t_apply: float  # the stamp, or the time it arrived if that was later
    force_body_n: tuple
    torque_body_n_m: tuple
    thrusts_n: tuple  # nominal thrust of each thruster (allocation, minimum impulse bit applied)
    wrench_undelivered_body: tuple  # commanded - nominal delivered (force [N], torque [N m])


class WheelCommand(NamedTuple):
    """A commanded set of wheel motor torques as accepted (clipped to the torque limit)."""

    seq: int
    t_stamp: float
    t_apply: float
    torque_commanded_n_m: tuple
    torque_n_m: tuple


class ManeuverRequest(NamedTuple):
    """An accepted delta-v command waiting for its burn (start, direction and duration are fixed when it starts:
    the ``burn_started`` event)."""

    seq: int
    t_cmd_s: float
    request_s: float  # the stamp, or the time it arrived if that was later
    dv_cmd_hill: tuple
    full_thrust: bool = False  # pushed with the layout's largest force (a CAM), not the point-mass chaser's thrust


class ThrusterBurn(NamedTuple):
    """A delta-v burn as started."""

    seq: int
    t_cmd_s: float
    start_s: float
    end_s: float
    dv_cmd_hill: tuple
    direction_body: tuple  # the delta-v's direction in chaser_body at the start
    thrusts_n: tuple  # nominal thrusts held (minimum impulse bit applied)
    force_n: float  # nominal force along direction_body
    mass_start_kg: float
    fuel_kg: float  # nominal fuel of the burn alone
    late: bool


class StepTotals(NamedTuple):
    """Means over one plant step of what the thrusters and wheels did (TruthSample fields)."""

    force_hill: np.ndarray
    force_body_n: np.ndarray
    torque_body_n_m: np.ndarray
    torque_hill_n_m: np.ndarray
    thruster_thrust_n: np.ndarray
    wheel_torque_n_m: np.ndarray
    firing: bool
    dv_thrust_hill: np.ndarray = None  # integral of the thrust acceleration over the step, hill axes [m/s]
