"""``Health``: what the injected faults leave of the chaser's thrusters and wheels (``flyby_sim.faults``).

The body keeps its hardware errors (``actuators.draw_thruster_errors``) and applies this on top: thruster i gives
max(gain_i f_i, leak_i) for a nominal thrust f_i (off: gain 0; degraded: gain < 1; stuck on: a leak), its force
direction turned by the rotation vector turn_i; wheel j gives its motor torque clipped to wheel_gain_j times its
limit (failed: 0).
"""

import dataclasses

import numpy as np

from flyby_sim.dynamics.rotation import quat_from_rotation_vector, quat_rotate


@dataclasses.dataclass(frozen=True)
class Health:
    """Per thruster: thrust gain, leak [N], direction turn [rad, chaser_body rotation vector]; per wheel: gain."""

    thrust_gain: tuple
    leak_n: tuple
    turn_rad: tuple  # (M,) of 3-tuples
    wheel_gain: tuple

    @classmethod
    def nominal(cls, n_thrusters, n_wheels):
        """Every thruster and wheel as built."""
        return cls((1.0,) * n_thrusters, (0.0,) * n_thrusters, ((0.0, 0.0, 0.0),) * n_thrusters, (1.0,) * n_wheels)

    def thrusts(self, nominal_n):
        """The thrusts the thrusters give for nominal thrusts [N] (a tuple)."""
        return tuple(max(f * g, leak) for f, g, leak in zip(nominal_n, self.thrust_gain, self.leak_n, strict=True))

    def directions(self, directions_body):
        """(M, 3) the thrusters' force directions [unit, chaser_body] turned by their turns."""
        turned = np.asarray(directions_body, dtype=float).copy()
        for i, turn in enumerate(self.turn_rad):
            if any(turn):
                turned[i] = quat_rotate(quat_from_rotation_vector(turn), turned[i])
        return turned

    def wheel_torques(self, torques_n_m, limits_n_m):
        """The motor torques [N m] the wheels give for the commanded ones, each clipped to gain times its limit."""
        return tuple(min(max(u, -g * lim), g * lim)
                     for u, g, lim in zip(torques_n_m, self.wheel_gain, limits_n_m, strict=True))
