"""Chaser thrusters: a time-tagged impulsive delta-v command becomes a finite burn (DESIGN §5).

A command (t_cmd, dv_hill) is validated, given execution errors drawn from the thruster random
stream, and scheduled as a burn at full thrust in the fixed hill direction of the errored delta-v,
by the burn chain of ``flyby_sim.dynamics.propulsion`` (start at the stamp, or at once when it has
passed, or when the burn before it ends; duration from the rocket equation).

Errors: magnitude times (1 + N(0, magnitude_error_sigma)); direction turned by an angle
N(0, direction_error_sigma_rad) about an axis perpendicular to the command, uniformly distributed
around it. Each accepted command draws exactly three numbers, whatever the sigmas; rejected
commands draw none.

Vectors in hill axes; SI units (N, s, kg, m/s).
"""

import math

import numpy as np

from flyby_sim.dynamics.propulsion import BurnRequest, ManeuverRejected, chain_burns, check_delta_v, insert_request


class ThrusterModel:
    """Validates, perturbs and schedules delta-v commands as finite burns (module doc)."""

    def __init__(self, config, rng):
        """config: ThrusterConfig; rng: numpy.random.Generator used for the execution errors only."""
        self.config = config
        self._rng = rng
        self.exhaust_velocity_mps = config.exhaust_velocity_mps
        self.mass_flow_kg_s = config.mass_flow_kg_s
        self._requests = []  # BurnRequest of the pending burns, in burn order
        self._pending = []  # Burn schedule matching _requests
        self._active = None
        self._seq = 0

    def check(self, dv_hill, mass_kg):
        """dv_hill as a float array if executable from mass mass_kg, else ManeuverRejected."""
        return check_delta_v(dv_hill, mass_kg, self.config)

    def perturb(self, dv_hill):
        """Errored delta-v [m/s]: magnitude and direction errors drawn from the stream (module doc)."""
        dv = np.asarray(dv_hill, dtype=float)
        z_mag, z_dir = self._rng.standard_normal(2)
        azimuth = 2.0 * math.pi * self._rng.random()
        dv_mps = math.sqrt(float(dv @ dv))
        u = dv / dv_mps
        # Unit vectors e1, e2 perpendicular to u, from the hill axis least aligned with it.
        e1 = np.cross(u, np.eye(3)[int(np.argmin(np.abs(u)))])
        e1 /= math.sqrt(float(e1 @ e1))
        e2 = np.cross(u, e1)
        axis = math.cos(azimuth) * e1 + math.sin(azimuth) * e2
        angle = self.config.direction_error_sigma_rad * z_dir
        # Rodrigues for an axis perpendicular to u: u cos(a) + (axis x u) sin(a).
        u_err = math.cos(angle) * u + math.sin(angle) * np.cross(axis, u)
        return dv_mps * (1.0 + self.config.magnitude_error_sigma * z_mag) * u_err

    def schedule(self, t_cmd, dv_hill, t_now, mass_now_kg):
        """Accept a command at sim time t_now [s]; returns its Burn as scheduled now.

        mass_now_kg is the chaser mass at t_now. Raises ManeuverRejected for a non-finite stamp or an
        unexecutable delta-v (check). A later command may shift this burn (chain order, module doc);
        the burn handed out by start_next is authoritative.
        """
        if not math.isfinite(t_cmd):
            raise ManeuverRejected(f'maneuver stamp t_cmd = {t_cmd} is not finite')
        dv_cmd = self.check(dv_hill, mass_now_kg)
        dv_exec = self.perturb(dv_cmd)
        request = BurnRequest(max(t_cmd, t_now), self._seq, t_cmd, tuple(dv_cmd.tolist()), tuple(dv_exec.tolist()))
        self._seq += 1
        self._requests = insert_request(self._requests, request)
        self._reschedule(mass_now_kg)
        return next(b for b in self._pending if b.seq == request.seq)

    def _reschedule(self, mass_now_kg):
        """Chain the pending burns after the active one: start, mass and duration of each."""
        if self._active is None:
            prev_end, mass = -math.inf, mass_now_kg
        else:
            prev_end, mass = self._active.end_s, self._active.mass_end_kg
        self._pending = chain_burns(self._requests, prev_end, mass, self.config)

    @property
    def active(self):
        """The burn in progress, or None."""
        return self._active

    @property
    def next_burn(self):
        """The next pending burn, or None."""
        return self._pending[0] if self._pending else None

    def start_next(self):
        """Make the next pending burn the active one and return it."""
        if self._active is not None:
            raise RuntimeError(f'burn {self._active.seq} is still active')
        self._requests.pop(0)
        self._active = self._pending.pop(0)
        return self._active

    def cancel_all(self):
        """Drop the active and every pending burn (the chaser was captured)."""
        self._requests, self._pending, self._active = [], [], None

    def finish_active(self):
        """End the active burn and return it."""
        burn, self._active = self._active, None
        return burn
