"""The plant: chaser relative translation with finite burns, target attitude, sensors, events.

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
"""

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from flyby_msgs_py.wire import Event
from flyby_sim.dynamics.attitude import AttitudePropagator, body_point_state, validated_inertia
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.constants import MU_EARTH_M3_S2
from flyby_sim.dynamics.orbital import (
    cw_accel_components,
    mean_motion_rad_s,
    nonlinear_relative_accel_components,
    q_eci_from_body,
    q_hill_from_body_many,
    rk4_step_floats,
)
from flyby_sim.dynamics.propulsion import ManeuverRejected, ThrusterConfig
from flyby_sim.dynamics.rotation import quat_normalize, quat_to_matrix
from flyby_sim.sensors import SampleSchedule, SensorModel
from flyby_sim.thrusters import ThrusterModel

DYNAMICS = ('nonlinear', 'cw')
_ZERO3 = (0.0, 0.0, 0.0)
ATTITUDE_CHUNK_STEPS = 100  # steps of target attitude evaluated at once (5 s at 20 Hz)


def _finite_vector(name, value, size):
    try:
        v = tuple(float(c) for c in value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f'{name} must be {size} numbers, got {value!r}') from exc
    if len(v) != size or not all(math.isfinite(c) for c in v):
        raise ValueError(f'{name} must be {size} finite numbers, got {value!r}')
    return v


@dataclasses.dataclass(frozen=True)
class PlantConfig:
    """Everything the plant needs; validated on construction (ValueError names the field)."""

    radius_m: float  # circular target orbit radius
    chaser_mass_kg: float
    r0_hill: tuple  # chaser position at t = 0 [m]
    v0_hill: tuple  # chaser velocity relative to the rotating hill frame at t = 0 [m/s]
    target_inertia: tuple  # 3x3 [kg m^2], body axes
    q_hill_from_body0: tuple  # target attitude at t = 0, (x, y, z, w)
    omega_body0: tuple  # target inertial angular velocity at t = 0, body axes [rad/s]
    thrusters: ThrusterConfig
    mu: float = MU_EARTH_M3_S2
    dynamics: str = 'nonlinear'  # 'nonlinear' (seed 000 eq 1) or 'cw' (eq 2)
    step_s: float = 0.05
    position_sigma_m: float = 0.0
    position_rate_hz: float = 10.0
    attitude_sigma_rad: float = 0.0
    attitude_rate_hz: float = 10.0
    restriction_sphere_radius_m: float = 0.0
    seed: int = 0

    def __post_init__(self):
        for name in ('radius_m', 'chaser_mass_kg', 'mu', 'step_s', 'position_rate_hz', 'attitude_rate_hz'):
            require_positive(name, getattr(self, name))
        for name in ('position_sigma_m', 'attitude_sigma_rad', 'restriction_sphere_radius_m'):
            require_positive(name, getattr(self, name), allow_zero=True)
        for name, size in (('r0_hill', 3), ('v0_hill', 3), ('q_hill_from_body0', 4), ('omega_body0', 3)):
            object.__setattr__(self, name, _finite_vector(name, getattr(self, name), size))
        try:
            inertia = validated_inertia(self.target_inertia)
        except ValueError as exc:
            raise ValueError(f'target_inertia: {exc}') from exc
        object.__setattr__(self, 'target_inertia', tuple(map(tuple, inertia.tolist())))
        try:
            quat_normalize(self.q_hill_from_body0)
        except ValueError as exc:
            raise ValueError(f'q_hill_from_body0: {exc}') from exc
        if self.dynamics not in DYNAMICS:
            raise ValueError(f'dynamics must be one of {DYNAMICS}, got {self.dynamics!r}')
        if not isinstance(self.thrusters, ThrusterConfig):
            raise ValueError(f'thrusters must be a ThrusterConfig, got {self.thrusters!r}')
        for name in ('position_rate_hz', 'attitude_rate_hz'):
            if getattr(self, name) * self.step_s > 1.0:
                raise ValueError(f'{name} = {getattr(self, name)} exceeds one sample per step '
                                 f'(step_s = {self.step_s})')
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise ValueError(f'seed must be a non-negative integer, got {self.seed!r}')


@dataclasses.dataclass(frozen=True, slots=True)
class TruthSample:
    """True state at the end of a step (hill frame; arrays are the caller's to keep)."""

    t: float  # [s]
    r_hill: np.ndarray  # chaser position [m]
    v_hill: np.ndarray  # chaser velocity relative to the rotating frame [m/s]
    q_hill_from_body: np.ndarray  # target attitude (x, y, z, w)
    omega_body: np.ndarray  # target inertial angular velocity, body axes [rad/s]
    force_hill: np.ndarray  # mean thrust force over the step (impulse / step_s) [N]
    mass_kg: float  # chaser mass
    fuel_used_kg: float  # since t = 0
    dv_applied_total_mps: float  # sum of |delta-v| delivered by the thrusters since t = 0
    firing: bool  # thrust was on during some part of the step


class Measurement(NamedTuple):
    """One sensor sample: kind 'relative_position' (value r_hill [m]) or 'target_attitude' (q_hill_from_body)."""

    kind: str
    t: float
    value: np.ndarray


class Plant:
    """Truth simulation of one chaser and its target, advanced in fixed steps of config.step_s.

    Events (drain_events): 'burn_started' and 'burn_ended' (OK), 'late_maneuver' (WARN, when a burn
    starts after its stamp), 'maneuver_rejected' (ERROR, with the ManeuverRejected reason) and
    'thrust_inside_restriction_sphere' (ERROR, once per burn, checked at both ends of every thrusting
    sub-step).
    """

    def __init__(self, config):
        self.config = config
        n = mean_motion_rad_s(config.radius_m, config.mu)
        self.mean_motion_rad_s = n
        if config.dynamics == 'nonlinear':
            radius_m = config.radius_m
            self._accel = lambda r, v, a: nonlinear_relative_accel_components(r, v, n, radius_m, a)
        else:
            self._accel = lambda r, v, a: cw_accel_components(r, v, n, a)
        thruster_seed, sensor_seed = np.random.SeedSequence(config.seed).spawn(2)
        self._thrusters = ThrusterModel(config.thrusters, np.random.default_rng(thruster_seed))
        self._sensors = SensorModel(np.random.default_rng(sensor_seed), config.position_sigma_m,
                                    config.attitude_sigma_rad)
        q_eci_from_body0 = q_eci_from_body(0.0, n, quat_normalize(config.q_hill_from_body0))
        self._attitude = AttitudePropagator(q_eci_from_body0, config.omega_body0, config.target_inertia)
        self._attitude_chunk = (0, [], [])  # first step index, q_hill_from_body rows, omega_body rows
        self._position_schedule = SampleSchedule(config.position_rate_hz, config.step_s)
        self._attitude_schedule = SampleSchedule(config.attitude_rate_hz, config.step_s)
        self._step_index = 0
        self._y = list(config.r0_hill + config.v0_hill)  # [r_hill; v_hill] as floats
        self._mass_kg = config.chaser_mass_kg
        self._dv_total_mps = 0.0
        self._burn_rhs = None
        self._restriction_reported = False
        self._r_body_captured = None
        self._events = []
        self._measurements = []
        self._last = self._truth(np.zeros(3), False)

    @property
    def t(self):
        """Current sim time [s]."""
        return self._step_index * self.config.step_s

    def truth(self):
        """The TruthSample of the current time (the last step's, or the initial state)."""
        return self._last

    def command_maneuver(self, t_stamp, dv_hill):
        """Schedule an impulsive delta-v dv_hill [m/s] to start at sim time t_stamp [s].

        Returns the thrusters.Burn as scheduled now (start_s, end_s, late, dv_hill to be delivered).
        Raises ManeuverRejected (and records an ERROR event) for an unexecutable command.
        """
        try:
            if self.captured:
                raise ManeuverRejected(f'the chaser is attached to the target; maneuver stamped {t_stamp} s dropped')
            return self._thrusters.schedule(t_stamp, dv_hill, self.t, self._mass_kg)
        except ManeuverRejected as exc:
            self._events.append(Event(self.t, 'ERROR', 'maneuver_rejected', exc.reason,
                                      dict(t_now=self.t, t_stamp=t_stamp, dv_hill=str(dv_hill))))
            raise

    def measurements(self):
        """Sensor samples due at the last step (list of Measurement)."""
        return self._measurements

    def drain_events(self):
        """Events since the last call, oldest first (list of Event)."""
        events, self._events = self._events, []
        return events

    @property
    def captured(self):
        """True once ``capture`` has attached the chaser to the target."""
        return self._r_body_captured is not None

    def capture(self):
        """Attach the chaser rigidly to the target where it is now (seed 000 section 2.2 (4)-(5)).

        From the next step on the chaser keeps its current position in target_body axes and moves
        with the target (r_hill = C r_body, v_hill = C (omega_body x r_body) - Omega^H x r_hill); truth
        keeps flowing. Pending and later maneuvers are dropped (the combined body's control is a later
        capability). Idempotent.
        """
        if self.captured:
            return
        c_hill_from_body = quat_to_matrix(self._last.q_hill_from_body)
        self._r_body_captured = c_hill_from_body.T @ np.array(self._y[:3])
        self._thrusters.cancel_all()
        self._events.append(Event(self.t, 'OK', 'captured', f'chaser attached to the target at t = {self.t:.3f} s',
                                  dict(t=self.t, r_hill=np.array(self._y[:3]), r_body=self._r_body_captured)))

    def step(self):
        """Advance exactly one step_s; returns the TruthSample at the new time."""
        if self.captured:
            return self._step_attached()
        thrusters = self._thrusters
        t = self.t
        self._step_index += 1
        t1 = self.t
        y = self._y
        impulse = [0.0, 0.0, 0.0]
        firing = False
        while t < t1:
            burn = thrusters.active
            if burn is None:
                upcoming = thrusters.next_burn
                if upcoming is None or upcoming.start_s > t:
                    t_end = t1 if upcoming is None else min(t1, upcoming.start_s)
                    y = rk4_step_floats(self._coast_rhs, t, y, t_end - t)
                    t = t_end
                    continue
                burn = self._start_burn(t)
            t_end = min(t1, burn.end_s)
            self._check_restriction(burn, t, y)
            y = rk4_step_floats(self._burn_rhs, t, y, t_end - t)
            mass_end = burn.mass_end_kg if t_end == burn.end_s else self._burn_mass(burn, t_end)
            self._dv_total_mps += thrusters.exhaust_velocity_mps * math.log(self._mass_kg / mass_end)
            force = self.config.thrusters.max_thrust_n * (t_end - t)
            for axis, u in enumerate(burn.direction_hill):
                impulse[axis] += force * u
            self._mass_kg = mass_end
            firing = True
            t = t_end
            self._check_restriction(burn, t, y)
            if t == burn.end_s:
                self._end_burn(t)
        self._y = y
        step_s = self.config.step_s
        self._last = self._truth(np.array(impulse) / step_s, firing)
        self._sample(self._last)
        return self._last

    def _step_attached(self):
        self._step_index += 1
        q_hill_from_body, omega_body = self._target_attitude()
        r_hill, v_hill = body_point_state(quat_to_matrix(q_hill_from_body), omega_body, self._r_body_captured,
                                          self.mean_motion_rad_s)  # eq 8-9 of a body-fixed point
        self._y = r_hill.tolist() + v_hill.tolist()
        self._last = self._truth(np.zeros(3), False)
        self._sample(self._last)
        return self._last

    def _coast_rhs(self, t, y):
        return (y[3], y[4], y[5], *self._accel(y[:3], y[3:], _ZERO3))

    def _burn_mass(self, burn, t):
        return burn.mass_start_kg - self._thrusters.mass_flow_kg_s * (t - burn.start_s)

    def _start_burn(self, t):
        burn = self._thrusters.start_next()
        thrust_n = self.config.thrusters.max_thrust_n
        ux, uy, uz = burn.direction_hill

        def burn_rhs(tau, y):
            k = thrust_n / self._burn_mass(burn, tau)  # F / m(t), mass falling linearly
            return (y[3], y[4], y[5], *self._accel(y[:3], y[3:], (k * ux, k * uy, k * uz)))

        self._burn_rhs = burn_rhs
        self._restriction_reported = False
        self._events.append(Event(self.t, 'OK', 'burn_started', f'burn {burn.seq} started at t = {t:.3f} s',
                                  dict(seq=burn.seq, t_cmd=burn.t_cmd_s, t_start=burn.start_s,
                                          t_end=burn.end_s, dv_cmd_hill=burn.dv_cmd_hill,
                                          dv_hill=burn.dv_hill, mass_kg=burn.mass_start_kg)))
        if burn.late:
            lateness = burn.start_s - burn.t_cmd_s
            self._events.append(Event(self.t, 'WARN', 'late_maneuver',
                                      f'burn {burn.seq} stamped {burn.t_cmd_s:.3f} s started {lateness:.3f} s late',
                                      dict(seq=burn.seq, t_cmd=burn.t_cmd_s, t_start=burn.start_s,
                                              lateness_s=lateness)))
        return burn

    def _end_burn(self, t):
        burn = self._thrusters.finish_active()
        self._burn_rhs = None
        self._events.append(Event(self.t, 'OK', 'burn_ended', f'burn {burn.seq} ended at t = {t:.3f} s',
                                  dict(seq=burn.seq, t_end=t, dv_hill=burn.dv_hill, fuel_kg=burn.fuel_kg,
                                          mass_kg=burn.mass_end_kg)))

    def _check_restriction(self, burn, t, y):
        """Record (once per burn) thrust applied inside the thruster-restriction sphere."""
        x, yy, z = y[:3]
        range_m = math.sqrt(x * x + yy * yy + z * z)
        radius_m = self.config.restriction_sphere_radius_m
        if range_m < radius_m and not self._restriction_reported:
            self._restriction_reported = True
            self._events.append(Event(self.t, 'ERROR', 'thrust_inside_restriction_sphere',
                                      f'burn {burn.seq} thrusts at {range_m:.3f} m, inside the '
                                      f'{radius_m:.3f} m restriction sphere',
                                      dict(seq=burn.seq, t=t, range_m=range_m,
                                              restriction_sphere_radius_m=radius_m)))

    def _target_attitude(self):
        """(q_hill_from_body, omega_body) at the current step, from the chunk of steps evaluated at once."""
        first, q_rows, omega_rows = self._attitude_chunk
        i = self._step_index - first
        if i >= len(q_rows):
            step_s = self.config.step_s
            first = self._step_index
            t_s = [k * step_s for k in range(first, first + ATTITUDE_CHUNK_STEPS)]  # as self.t, to the bit
            q_eci_from_body, omega_body = self._attitude.states_at(t_s)
            q_rows = list(q_hill_from_body_many(t_s, self.mean_motion_rad_s, q_eci_from_body))
            omega_rows = list(omega_body)
            self._attitude_chunk = (first, q_rows, omega_rows)
            i = 0
        return q_rows[i], omega_rows[i]

    def _truth(self, force_hill, firing):
        q_hill_from_body, omega_body = self._target_attitude()
        y = self._y
        return TruthSample(t=self.t, r_hill=np.array(y[:3]), v_hill=np.array(y[3:]),
                           q_hill_from_body=q_hill_from_body, omega_body=omega_body, force_hill=force_hill,
                           mass_kg=self._mass_kg, fuel_used_kg=self.config.chaser_mass_kg - self._mass_kg,
                           dv_applied_total_mps=self._dv_total_mps, firing=firing)

    def _sample(self, truth):
        self._measurements = []
        if self._position_schedule.is_sample_step(self._step_index):
            self._measurements.append(Measurement('relative_position', truth.t,
                                                  self._sensors.relative_position(truth.r_hill)))
        if self._attitude_schedule.is_sample_step(self._step_index):
            self._measurements.append(Measurement('target_attitude', truth.t,
                                                  self._sensors.target_attitude(truth.q_hill_from_body)))


def plant_config_from_scenario(scenario):
    """The plant configuration of a validated scenario (``flyby_sim.scenario.Scenario``)."""
    sc = scenario
    th = sc.chaser.thrusters
    return PlantConfig(
        radius_m=sc.orbit_radius_m,
        mu=sc.orbit.mu_m3_s2,
        chaser_mass_kg=sc.chaser.mass_kg,
        r0_hill=tuple(sc.chaser.initial_position_hill_m),
        v0_hill=tuple(sc.chaser.initial_velocity_hill_mps),
        target_inertia=tuple(map(tuple, sc.target_inertia)),
        q_hill_from_body0=tuple(sc.q_hill_from_body0),
        omega_body0=tuple(sc.omega_body0_rad_s),
        thrusters=ThrusterConfig(
            max_thrust_n=th.max_thrust_n, isp_s=th.isp_s,
            min_impulse_bit_ns=th.min_impulse_bit_ns,
            max_delta_v_per_maneuver_mps=th.max_delta_v_per_maneuver_mps,
            magnitude_error_sigma=th.magnitude_error_sigma,
            direction_error_sigma_rad=math.radians(th.direction_error_sigma_deg)),
        dynamics=sc.simulation.dynamics,
        step_s=sc.simulation.step_s,
        position_sigma_m=sc.sensors.relative_position.noise_sigma_m,
        position_rate_hz=sc.sensors.relative_position.rate_hz,
        attitude_sigma_rad=math.radians(sc.sensors.target_attitude.noise_sigma_deg),
        attitude_rate_hz=sc.sensors.target_attitude.rate_hz,
        restriction_sphere_radius_m=sc.planner.restriction_sphere_radius_m,
        seed=sc.seed,
    )
