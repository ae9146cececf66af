"""The one interface of guidance's modes (``GuidanceMode``) and what passes through it: a chaser estimate in, the
outputs to publish out (``guidance.Maneuver``, ``AttitudeCommandStamped``, ``wire.Event``), in order."""

import dataclasses
from typing import NamedTuple

import numpy as np

from flyby_msgs_py.wire import Event


class ChaserEstimate(NamedTuple):
    """A chaser estimate (estimation/chaser/odom): stamp t [s], position [m] and velocity [m/s] in hill, and the
    rigid-body chaser's attitude q_hill_from_body and body rate [rad/s, chaser_body] as given (None without them)."""

    t: float
    r_hill: np.ndarray
    v_hill: np.ndarray
    q_hill_from_body: object
    omega_body: object


@dataclasses.dataclass(frozen=True)
class AttitudeCommandStamped:
    """guidance/wheels and guidance/wrench: from t [s] for hold_s [s], the wheels' motor torques [N m], the
    thrusters' torque about the CoM in chaser_body axes [N m] and their force in chaser_body axes [N] (zero but
    while tracking an optimal approach: the fly-by translates by maneuvers)."""

    t: float
    hold_s: float
    wheel_torque_n_m: np.ndarray
    thruster_torque_body_n_m: np.ndarray
    force_body_n: tuple = (0.0, 0.0, 0.0)


class GuidanceMode:
    """A mode of guidance. ``command`` gives the outputs for a chaser estimate, or None where the estimate is not the
    mode's (the next mode's then); ``on_event`` takes an event of mission/events and gives the outputs it releases.
    Events a mode emits carry ``source`` (the node's name)."""

    def __init__(self, source):
        self.source = source

    def command(self, estimate, phase):
        """The outputs for the ChaserEstimate in the supervisor's phase, or None where it is not this mode's."""
        raise NotImplementedError

    def on_event(self, event, phase):
        """The outputs an event of mission/events releases (none by default)."""
        return []

    def drop_plan(self):
        """Forget the plan (the supervisor's HOLD: a plan of the standby it interrupted is never flown, the next
        one is made after it); nothing by default."""

    def _event(self, t, level, name, message, values):
        return Event(t, level, name, message, values, self.source)
