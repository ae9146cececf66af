"""Thruster limits, the rocket equation and the chain of finite burns a list of delta-v commands makes.

One model for everyone who must know how a commanded delta-v is executed: the plant's thrusters
(``flyby_sim.thrusters``, which add the execution errors), the navigation filter (which models the
commanded burns as known inputs) and guidance (the mass left after its burns).

A command (t_cmd, dv_hill) is a burn at full thrust F in the fixed direction of dv, starting at its
requested time: the stamp, or the time the command was accepted if the stamp had passed. Burns never
overlap: the pending ones run in order of (requested start, command number), each starting when the
one before it ends if that is later (then it is late). The duration follows the rocket equation with
mdot = F / (Isp g0), so the delta-v delivered, integral of F/m dt = Isp g0 ln(m0/m1), equals |dv|
exactly; the fuel is m0 (1 - exp(-|dv| / (Isp g0))).

Vectors in hill axes; SI units (N, s, kg, m/s).
"""

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from flyby_msgs_py import params
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.constants import STANDARD_GRAVITY_M_S2


class ManeuverRejected(Exception):
    """A delta-v command the thrusters cannot execute; ``reason`` says why, naming the value."""

    def __init__(self, reason):
        super().__init__(reason)
        self.reason = reason


@params.record
class ThrusterConfig:
    """Thruster parameters (scenario chaser.thrusters, flyby_msgs_py.params); values validated on construction
    (ValueError names the field)."""

    max_thrust_n: float = params.key('chaser.thrusters.max_thrust_n')
    isp_s: float = params.key('chaser.thrusters.isp_s')
    min_impulse_bit_ns: float = params.key('chaser.thrusters.min_impulse_bit_ns')
    max_delta_v_per_maneuver_mps: float = params.key('chaser.thrusters.max_delta_v_per_maneuver_mps')
    magnitude_error_sigma: float = params.key('chaser.thrusters.magnitude_error_sigma')  # fraction of |dv|, 1-sigma
    direction_error_sigma_rad: float = params.key('chaser.thrusters.direction_error_sigma_deg', math.radians)

    def __post_init__(self):
        require_positive('max_thrust_n', self.max_thrust_n)
        require_positive('isp_s', self.isp_s)
        require_positive('min_impulse_bit_ns', self.min_impulse_bit_ns, allow_zero=True)
        require_positive('max_delta_v_per_maneuver_mps', self.max_delta_v_per_maneuver_mps)
        require_positive('magnitude_error_sigma', self.magnitude_error_sigma, allow_zero=True)
        require_positive('direction_error_sigma_rad', self.direction_error_sigma_rad, allow_zero=True)

    @property
    def exhaust_velocity_mps(self):
        """Isp g0 [m/s]."""
        return self.isp_s * STANDARD_GRAVITY_M_S2

    @property
    def mass_flow_kg_s(self):
        """Propellant flow at full thrust, F / (Isp g0) [kg/s]."""
        return self.max_thrust_n / self.exhaust_velocity_mps


def fuel_for_delta_v_kg(mass_kg, dv_mps, exhaust_velocity_mps):
    """Propellant m0 (1 - exp(-dv / ve)) [kg] for a delta-v dv_mps from mass mass_kg (rocket equation)."""
    return -mass_kg * math.expm1(-dv_mps / exhaust_velocity_mps)


def delta_v_for_fuel_mps(mass_kg, fuel_kg, exhaust_velocity_mps):
    """Delta-v ve ln(m0 / (m0 - fuel)) [m/s] that fuel_kg of propellant gives from mass mass_kg."""
    return exhaust_velocity_mps * math.log(mass_kg / (mass_kg - fuel_kg))


def check_delta_v(dv_hill, mass_kg, config):
    """dv_hill as a float array if the thrusters (ThrusterConfig) can execute it from mass_kg, else
    ManeuverRejected naming the value."""
    dv = np.asarray(dv_hill, dtype=float)
    if dv.shape != (3,):
        raise ManeuverRejected(f'dv_hill must have 3 components, got {dv_hill!r}')
    if not np.all(np.isfinite(dv)):
        raise ManeuverRejected(f'dv_hill {dv.tolist()} has non-finite components')
    dv_mps = math.sqrt(float(dv @ dv))
    limit = config.max_delta_v_per_maneuver_mps
    if dv_mps > limit:
        raise ManeuverRejected(
            f'|dv_hill| = {dv_mps:.6g} m/s exceeds max_delta_v_per_maneuver_mps = {limit:.6g} m/s')
    impulse = mass_kg * dv_mps
    if dv_mps == 0.0 or impulse < config.min_impulse_bit_ns:
        raise ManeuverRejected(
            f'impulse m |dv_hill| = {impulse:.6g} N s (|dv_hill| = {dv_mps:.6g} m/s, mass '
            f'{mass_kg:.6g} kg) is below min_impulse_bit_ns = {config.min_impulse_bit_ns:.6g} N s')
    return dv


class BurnRequest(NamedTuple):
    """An accepted command waiting to be burnt: requested start, command number, stamp, the commanded
    delta-v and the delta-v the burn will deliver (the commanded one, or with execution errors)."""

    request_s: float
    seq: int
    t_cmd_s: float
    dv_cmd_hill: tuple
    dv_hill: tuple


@dataclasses.dataclass(frozen=True)
class Burn:
    """One scheduled finite burn at full thrust; all times sim time [s]."""

    seq: int  # command number, counting accepted commands from 0
    t_cmd_s: float  # the command's stamp
    start_s: float
    end_s: float
    dv_cmd_hill: tuple  # commanded delta-v [m/s]
    dv_hill: tuple  # delta-v the burn delivers [m/s]
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

    def mass_at(self, t, mass_flow_kg_s):
        """Chaser mass [kg] at time t inside the burn (linear fall at the full-thrust flow)."""
        return self.mass_start_kg - mass_flow_kg_s * (t - self.start_s)


def insert_request(requests, request):
    """The pending requests with one more, in burn order: requested start, then command number."""
    return sorted([*requests, request], key=lambda r: (r.request_s, r.seq))


def chain_burns(requests, prev_end_s, mass_kg, config):
    """The Burns of the pending requests (in burn order) after a burn ending at prev_end_s
    (-inf: none) with mass_kg left then: start, duration and mass of each along the chain."""
    ve, mdot = config.exhaust_velocity_mps, config.mass_flow_kg_s
    burns = []
    for request in requests:
        start = max(request.request_s, prev_end_s)
        dv_mps = math.sqrt(sum(c * c for c in request.dv_hill))
        fuel = fuel_for_delta_v_kg(mass_kg, dv_mps, ve)
        burn = Burn(seq=request.seq, t_cmd_s=request.t_cmd_s, start_s=start, end_s=start + fuel / mdot,
                    dv_cmd_hill=request.dv_cmd_hill, dv_hill=request.dv_hill, mass_start_kg=mass_kg,
                    fuel_kg=fuel, late=start > request.t_cmd_s)
        burns.append(burn)
        prev_end_s, mass_kg = burn.end_s, burn.mass_end_kg
    return burns
