"""Chaser thrusters: a time-tagged impulsive delta-v command becomes a finite burn (DESIGN §5).

A command (t_cmd, dv_hill) is validated, given execution errors drawn from the thruster random
stream, and scheduled as a burn at full thrust in the fixed hill direction of the errored delta-v.
The burn starts exactly at t_cmd, or at once (t_now) when t_cmd has passed, or when the burn
scheduled before it ends; either of the last two makes it late. Burns never overlap: the pending
ones run in order of their requested start (max(t_cmd, t_now at command), then command order), and
their start, duration and mass are recomputed along that chain whenever a command is added.

The duration follows the rocket equation with mdot = F / (Isp g0), so the delta-v delivered,
integral of F/m dt = Isp g0 ln(m0/m1), equals the errored delta-v exactly; the fuel is
m0 (1 - exp(-dv / (Isp g0))).

Errors: magnitude times (1 + N(0, magnitude_error_sigma)); direction turned by an angle
N(0, direction_error_sigma_rad) about an axis perpendicular to the command, uniformly distributed
around it. Each accepted command draws exactly three numbers, whatever the sigmas; rejected
commands draw none.

Vectors in hill axes; SI units (N, s, kg, m/s).
"""

import dataclasses
import math

import numpy as np

from flyby_sim.checks import require_positive

STANDARD_GRAVITY_M_S2 = 9.80665


class ManeuverRejected(Exception):
    """A delta-v command the thrusters cannot execute; ``reason`` says why, naming the value."""

    def __init__(self, reason):
        super().__init__(reason)
        self.reason = reason


@dataclasses.dataclass(frozen=True)
class ThrusterConfig:
    """Thruster parameters; values validated on construction (ValueError names the field)."""

    max_thrust_n: float
    isp_s: float
    min_impulse_bit_ns: float
    max_delta_v_per_maneuver_mps: float
    magnitude_error_sigma: float = 0.0  # fraction of |dv|, 1-sigma
    direction_error_sigma_rad: float = 0.0  # 1-sigma

    def __post_init__(self):
        require_positive('max_thrust_n', self.max_thrust_n)
        require_positive('isp_s', self.isp_s)
        require_positive('min_impulse_bit_ns', self.min_impulse_bit_ns, allow_zero=True)
        require_positive('max_delta_v_per_maneuver_mps', self.max_delta_v_per_maneuver_mps)
        require_positive('magnitude_error_sigma', self.magnitude_error_sigma, allow_zero=True)
        require_positive('direction_error_sigma_rad', self.direction_error_sigma_rad, allow_zero=True)


@dataclasses.dataclass(frozen=True)
class Burn:
    """One scheduled finite burn at full thrust; all times sim time [s]."""

    seq: int  # command number, counting accepted commands from 0
    t_cmd_s: float  # the command's stamp
    start_s: float
    end_s: float
    dv_cmd_hill: tuple  # commanded delta-v [m/s]
    dv_hill: tuple  # errored delta-v the burn delivers [m/s]
    mass_start_kg: float
    fuel_kg: float
    late: bool  # start_s > t_cmd_s

    @property
    def dv_mps(self):
        """|dv_hill| [m/s]."""
        return math.sqrt(sum(c * c for c in self.dv_hill))

    @property
    def direction_hill(self):
        """Unit thrust direction in hill axes (fixed during the burn)."""
        norm = self.dv_mps
        return tuple(c / norm for c in self.dv_hill)

    @property
    def mass_end_kg(self):
        """Chaser mass when the burn ends [kg]."""
        return self.mass_start_kg - self.fuel_kg


def fuel_for_delta_v_kg(mass_kg, dv_mps, exhaust_velocity_mps):
    """Propellant m0 (1 - exp(-dv / ve)) [kg] for a delta-v dv_mps from mass mass_kg (rocket equation)."""
    return -mass_kg * math.expm1(-dv_mps / exhaust_velocity_mps)


class ThrusterModel:
    """Validates, perturbs and schedules delta-v commands as finite burns (module doc)."""

    def __init__(self, config, rng):
        """config: ThrusterConfig; rng: numpy.random.Generator used for the execution errors only."""
        self.config = config
        self._rng = rng
        self.exhaust_velocity_mps = config.isp_s * STANDARD_GRAVITY_M_S2
        self.mass_flow_kg_s = config.max_thrust_n / self.exhaust_velocity_mps
        self._requests = []  # (request_s, seq, t_cmd, dv_cmd, dv_exec) of pending burns, sorted
        self._pending = []  # Burn schedule matching _requests
        self._active = None
        self._seq = 0

    def check(self, dv_hill, mass_kg):
        """dv_hill as a float array if executable from mass mass_kg, else ManeuverRejected."""
        dv = np.asarray(dv_hill, dtype=float)
        if dv.shape != (3,):
            raise ManeuverRejected(f'dv_hill must have 3 components, got {dv_hill!r}')
        if not np.all(np.isfinite(dv)):
            raise ManeuverRejected(f'dv_hill {dv.tolist()} has non-finite components')
        dv_mps = math.sqrt(float(dv @ dv))
        limit = self.config.max_delta_v_per_maneuver_mps
        if dv_mps > limit:
            raise ManeuverRejected(
                f'|dv_hill| = {dv_mps:.6g} m/s exceeds max_delta_v_per_maneuver_mps = {limit:.6g} m/s')
        impulse = mass_kg * dv_mps
        if dv_mps == 0.0 or impulse < self.config.min_impulse_bit_ns:
            raise ManeuverRejected(
                f'impulse m |dv_hill| = {impulse:.6g} N s (|dv_hill| = {dv_mps:.6g} m/s, mass '
                f'{mass_kg:.6g} kg) is below min_impulse_bit_ns = {self.config.min_impulse_bit_ns:.6g} N s')
        return dv

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
        request = (max(t_cmd, t_now), self._seq, t_cmd, tuple(dv_cmd.tolist()), tuple(dv_exec.tolist()))
        self._seq += 1
        self._requests.append(request)
        self._requests.sort(key=lambda r: (r[0], r[1]))
        self._reschedule(mass_now_kg)
        return next(b for b in self._pending if b.seq == request[1])

    def _reschedule(self, mass_now_kg):
        """Chain the pending burns after the active one: start, mass and duration of each."""
        if self._active is None:
            prev_end, mass = -math.inf, mass_now_kg
        else:
            prev_end, mass = self._active.end_s, self._active.mass_end_kg
        self._pending = []
        for request_s, seq, t_cmd, dv_cmd, dv_exec in self._requests:
            start = max(request_s, prev_end)
            dv_mps = math.sqrt(sum(c * c for c in dv_exec))
            fuel = fuel_for_delta_v_kg(mass, dv_mps, self.exhaust_velocity_mps)
            burn = Burn(seq=seq, t_cmd_s=t_cmd, start_s=start, end_s=start + fuel / self.mass_flow_kg_s,
                        dv_cmd_hill=dv_cmd, dv_hill=dv_exec, mass_start_kg=mass, fuel_kg=fuel,
                        late=start > t_cmd)
            self._pending.append(burn)
            prev_end, mass = burn.end_s, burn.mass_end_kg

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
