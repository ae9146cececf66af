"""Chaser relative navigation: a Kalman filter on the chaser's relative state in the hill frame.

State x = [r_hill (3) [m]; v_hill (3) [m/s]], v_hill the velocity relative to the rotating hill frame
(seed 000 section 3: x along-track, y orbit anti-normal, z toward Earth's centre; the frame turns at
[0, -n, 0]). Built on ``filterpy.kalman.KalmanFilter`` (linear KF; with ``dynamics='nonlinear'`` an
EKF in the sense of seed 004 section 2.2: the mean follows the nonlinear model, the covariance its
linearization).

Process model (predict):
  * mean: x(t+dt) = Phi(dt) x(t), Phi the CW transition matrix of seed 000 eq 22
    (``dynamics='cw'``, the default), or RK4 of the exact two-body relative dynamics
    (``dynamics='nonlinear'``, seed 000 eq 1, needs ``radius_m``). During a burn the commanded thrust
    acceleration is added and the mean is always integrated with RK4 (CW or nonlinear acceleration).
  * covariance: P = Phi P Phi' + Q(dt) with the white-acceleration (double-integrator) form per axis
        Q = q [[dt^3/3, dt^2/2], [dt^2/2, dt]],  q = accel_psd_m2_s3 [m^2/s^3].
    It neglects the CW coupling inside Q, a relative error O(n dt) (1e-4 at dt = 0.1 s).
    At 50 m the CW linearization error of the mean is a few micrometres over 60 s (test
    test_cw_model_vs_plant_truth_coasting), far below the 1 cm sensor noise, hence CW is the default.

Known inputs (``add_maneuver``): a time-tagged impulsive delta-v command is modelled the way the plant
executes it (``flyby_sim.thrusters``): a burn at max thrust F in the commanded direction starting at
the stamp (or at the end of the previously added burn, whichever is later), thrust acceleration
F / m(t) with the mass falling at F / (Isp g0), duration from the rocket equation so that the burn
delivers exactly the commanded delta-v. The mass is tracked over the maneuvers. Without thruster data
a burn of given duration has constant acceleration dv / T; duration 0 is an impulse at the stamp.
The residual left is only the unknown execution error; it enters the covariance when the burn starts
as P += G Qdv G' with
    Qdv = |dv|^2 (s_mag^2 u u' + s_dir^2 / 2 (I - u u')),   G = [(tau - T/2) I; I],
u the command direction, T the burn duration, tau the time since the burn start (0 for a burn
known in time). The thrusters' error is a constant acceleration dv_err / T over the burn, which at
the burn end is [dv_err T / 2; dv_err]: injecting G dv_err at the start and coasting gives exactly
that at the end (during the burn the injected velocity spread is conservative).

A command stamped before the filter time ("late" for the filter) is applied retroactively: the
CW response to the part of the burn already past is added to the mean. Measurements already
processed in between were not explained by the burn; the gate and the outlier reset below cover
what that leaves.

Measurements (``update``): r_hill with per-axis noise sigma, H = [I 0]. The normalized innovation
squared NIS = y' S^-1 y (y = z - H x, S = H P H' + R) is gated against the chi-square(3) quantile of
``gate_probability``. Outcomes (``UpdateResult.kind``): 'initialized', 'accepted', and the
rejections 'non_finite', 'stale' (t before the filter time), 'outlier' (NIS above the gate), counted
in ``counts``. After ``max_consecutive_outliers`` outliers in a row the filter assumes it is lost and
resets its position to the measurement (kind 'reset', counted too). The covariance update is Joseph
form (filterpy's), followed by explicit symmetrization.

Initialization: from the first finite measurement, r = z, P_r = sigma^2 I, v = 0 with
P_v = initial_velocity_sigma_mps^2 I (default 0.1 m/s: the chaser holds station before the approach),
or explicitly with ``initialize``.

No rclpy. SI units throughout.
"""

import copy
import dataclasses
import math
from typing import NamedTuple

import numpy as np
from filterpy.kalman import KalmanFilter
from scipy.stats import chi2

from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.orbital import cw_accel, cw_transition_matrix, mean_motion_rad_s, nonlinear_relative_accel, rk4_step
from flyby_sim.plant import plant_config_from_scenario
from flyby_sim.dynamics.propulsion import ManeuverRejected, ThrusterConfig, fuel_for_delta_v_kg
from flyby_sim.thrusters import ThrusterModel

DYNAMICS = ('cw', 'nonlinear')
REJECTION_KINDS = ('non_finite', 'stale', 'outlier')
DEFAULT_ACCEL_PSD_M2_S3 = 1.0e-9
_I3 = np.eye(3)

__all__ = ['DEFAULT_ACCEL_PSD_M2_S3', 'DYNAMICS', 'REJECTION_KINDS', 'ManeuverRejected', 'NavState',
           'RelativeNavConfig', 'RelativeNavFilter', 'ScheduledBurn', 'UpdateResult',
           'relative_nav_config_from_scenario']


@dataclasses.dataclass(frozen=True)
class RelativeNavConfig:
    """Filter parameters; validated on construction (ValueError names the field)."""

    mean_motion_rad_s: float  # n of the target orbit
    position_sigma_m: float  # measurement noise, 1-sigma per axis
    accel_psd_m2_s3: float = DEFAULT_ACCEL_PSD_M2_S3  # q: white-acceleration spectral density
    initial_velocity_sigma_mps: float = 0.1  # velocity prior, 1-sigma per axis
    gate_probability: float = 0.9999  # chi2(3) gate on the NIS
    max_consecutive_outliers: int = 20  # then reset to the measurement (2 s at 10 Hz)
    dynamics: str = 'cw'  # 'cw' (seed 000 eq 22) or 'nonlinear' (seed 000 eq 1, needs radius_m)
    radius_m: float = None  # target orbit radius, for 'nonlinear'
    thrusters: ThrusterConfig = None  # max thrust, Isp, execution-error sigmas
    chaser_mass_kg: float = None  # mass at filter start, with thrusters
    max_rk4_step_s: float = 1.0  # RK4 step bound for burns and nonlinear coasting

    def __post_init__(self):
        require_positive('mean_motion_rad_s', self.mean_motion_rad_s)
        require_positive('position_sigma_m', self.position_sigma_m)
        require_positive('accel_psd_m2_s3', self.accel_psd_m2_s3, allow_zero=True)
        require_positive('initial_velocity_sigma_mps', self.initial_velocity_sigma_mps)
        require_positive('max_rk4_step_s', self.max_rk4_step_s)
        if not (0.0 < self.gate_probability < 1.0):
            raise ValueError(f'gate_probability must be in (0, 1), got {self.gate_probability!r}')
        if isinstance(self.max_consecutive_outliers, bool) or not isinstance(
                self.max_consecutive_outliers, (int, np.integer)) or self.max_consecutive_outliers < 1:
            raise ValueError(f'max_consecutive_outliers must be an integer >= 1, got '
                             f'{self.max_consecutive_outliers!r}')
        if self.dynamics not in DYNAMICS:
            raise ValueError(f'dynamics must be one of {DYNAMICS}, got {self.dynamics!r}')
        if self.dynamics == 'nonlinear':
            if self.radius_m is None:
                raise ValueError("radius_m is required with dynamics='nonlinear'")
            require_positive('radius_m', self.radius_m)
        if self.thrusters is not None:
            if not isinstance(self.thrusters, ThrusterConfig):
                raise ValueError(f'thrusters must be a ThrusterConfig or None, got {self.thrusters!r}')
            if self.chaser_mass_kg is None:
                raise ValueError('chaser_mass_kg is required with thrusters')
        if self.chaser_mass_kg is not None:
            require_positive('chaser_mass_kg', self.chaser_mass_kg)


def relative_nav_config_from_scenario(scenario, **overrides):
    """RelativeNavConfig of a validated scenario (orbit, sensor noise, thrusters, chaser mass).

    The orbit, thruster and sensor values are read through ``plant_config_from_scenario`` so the
    filter and the plant see the same numbers; ``overrides`` replace any field.
    """
    plant = plant_config_from_scenario(scenario)
    fields = dict(mean_motion_rad_s=mean_motion_rad_s(plant.radius_m, plant.mu), radius_m=plant.radius_m,
                  position_sigma_m=plant.position_sigma_m, thrusters=plant.thrusters,
                  chaser_mass_kg=plant.chaser_mass_kg)
    fields.update(overrides)
    return RelativeNavConfig(**fields)


class NavState(NamedTuple):
    """Filter output at time t: r_hill [m], v_hill [m/s], covariance 6x6 of [r; v] (copies)."""

    t: float
    r_hill: np.ndarray
    v_hill: np.ndarray
    covariance: np.ndarray


class UpdateResult(NamedTuple):
    """Outcome of one measurement: kind in 'initialized', 'accepted', 'reset' or REJECTION_KINDS."""

    kind: str
    accepted: bool  # the measurement changed the state (initialized, accepted, reset)
    t: float
    nis: float  # normalized innovation squared (nan when not computed)
    reason: str


@dataclasses.dataclass
class ScheduledBurn:
    """A maneuver as the filter models it (times sim time [s], hill axes)."""

    t_cmd_s: float
    start_s: float
    end_s: float  # == start_s for an impulse
    dv_hill: np.ndarray  # commanded delta-v [m/s]
    thrust_n: float  # F, or |dv| m / T for a constant-acceleration burn (m = 1 without mass data)
    mass_start_kg: float
    mass_flow_kg_s: float
    magnitude_error_at_end: bool  # the plant's burn: a magnitude error lengthens or shortens it
    started: bool = False

    @property
    def duration_s(self):
        return self.end_s - self.start_s

    @property
    def direction_hill(self):
        return self.dv_hill / np.linalg.norm(self.dv_hill)

    def accel_hill(self, t):
        """Commanded thrust acceleration [m/s^2] at time t inside the burn."""
        return self.direction_hill * (self.thrust_n / (self.mass_start_kg - self.mass_flow_kg_s * (t - self.start_s)))


def _white_accel_q(q, dt):
    """Discrete process noise of white acceleration with density q over dt (double-integrator form)."""
    q11, q12, q22 = q * dt**3 / 3.0, q * dt**2 / 2.0, q * dt
    return np.block([[q11 * _I3, q12 * _I3], [q12 * _I3, q22 * _I3]])


class RelativeNavFilter:
    """Kalman filter for the chaser's relative state (module doc). Not thread-safe."""

    def __init__(self, config):
        if not isinstance(config, RelativeNavConfig):
            raise ValueError(f'config must be a RelativeNavConfig, got {config!r}')
        self.config = config
        self._n = config.mean_motion_rad_s
        kf = KalmanFilter(dim_x=6, dim_z=3)
        kf.H = np.hstack((_I3, np.zeros((3, 3))))
        kf.R = config.position_sigma_m**2 * _I3
        self._kf = kf
        self._gate = float(chi2.ppf(config.gate_probability, df=3))
        self._t = None
        self._burns = []  # scheduled, not finished, in start order
        self._mass_kg = config.chaser_mass_kg  # after every burn added so far
        self._thruster_model = None
        if config.thrusters is not None:
            # Used only for validation (check) and the exhaust velocity and mass flow; never draws.
            self._thruster_model = ThrusterModel(config.thrusters, rng=None)
        self._consecutive_outliers = 0
        self.counts = dict.fromkeys(('initialized', 'accepted', 'reset') + REJECTION_KINDS, 0)

    # ---------------------------------------------------------------------------------------------
    # State

    @property
    def initialized(self):
        return self._t is not None

    @property
    def t(self):
        """Filter time [s] (None before initialization)."""
        return self._t

    @property
    def gate_threshold(self):
        """NIS above which a measurement is an outlier (chi2(3) quantile of gate_probability)."""
        return self._gate

    def initialize(self, t, r_hill, v_hill=(0.0, 0.0, 0.0), covariance=None):
        """Set the state at time t; covariance defaults to diag(sigma_pos^2 I, sigma_v0^2 I)."""
        x = np.concatenate((np.asarray(r_hill, dtype=float).reshape(3), np.asarray(v_hill, dtype=float).reshape(3)))
        if not (math.isfinite(t) and np.all(np.isfinite(x))):
            raise ValueError(f'initialize: t {t!r}, r_hill {r_hill!r}, v_hill {v_hill!r} must be finite')
        if covariance is None:
            covariance = np.diag([self.config.position_sigma_m**2] * 3
                                 + [self.config.initial_velocity_sigma_mps**2] * 3)
        covariance = np.array(covariance, dtype=float)
        if covariance.shape != (6, 6) or not np.all(np.isfinite(covariance)):
            raise ValueError(f'initialize: covariance must be a finite 6x6 matrix, got shape {covariance.shape}')
        self._kf.x = x.reshape(6, 1)
        self._kf.P = 0.5 * (covariance + covariance.T)
        self._t = float(t)
        self._consecutive_outliers = 0

    def state(self):
        """NavState at the filter time."""
        self._require_initialized('state')
        x = self._kf.x[:, 0]
        return NavState(self._t, x[:3].copy(), x[3:].copy(), self._kf.P.copy())

    def predict_to(self, t):
        """Propagate the filter to time t >= filter time (no measurement) and return the NavState.

        This moves the filter time: measurements stamped before t are then stale. For output at a
        time without touching the filter use ``state_at``.
        """
        self._require_initialized('predict_to')
        if not math.isfinite(t):
            raise ValueError(f'predict_to: t = {t!r} is not finite')
        if t < self._t:
            raise ValueError(f'predict_to: t = {t!r} is before the filter time {self._t!r}')
        self._advance(float(t))
        return self.state()

    def state_at(self, t):
        """NavState predicted to t >= filter time, leaving the filter unchanged."""
        return copy.deepcopy(self).predict_to(t)

    @property
    def burns(self):
        """Maneuvers scheduled and not yet finished (ScheduledBurn, copies)."""
        return [dataclasses.replace(b, dv_hill=b.dv_hill.copy()) for b in self._burns]

    @property
    def mass_kg(self):
        """Modelled chaser mass after all maneuvers added so far [kg] (None without mass data)."""
        return self._mass_kg

    # ---------------------------------------------------------------------------------------------
    # Inputs

    def add_maneuver(self, t_start, dv_hill, burn_duration_s=None):
        """Add a commanded maneuver: delta-v dv_hill [m/s] stamped t_start [s]; returns its ScheduledBurn.

        burn_duration_s None: the plant's finite burn from the thruster data (module doc), or an
        impulse at the stamp without thruster data; a number: a constant-acceleration burn of that
        duration (0 = impulse). Raises ManeuverRejected for a delta-v the thrusters reject (as the
        plant would: the maneuver then never happens) and ValueError for a malformed input.
        """
        if not math.isfinite(t_start):
            raise ValueError(f'add_maneuver: t_start = {t_start!r} is not finite')
        dv = np.asarray(dv_hill, dtype=float)
        if dv.shape != (3,) or not np.all(np.isfinite(dv)) or not np.any(dv):
            raise ValueError(f'add_maneuver: dv_hill must be 3 finite numbers, not all zero, got {dv_hill!r}')
        if burn_duration_s is not None:
            require_positive('burn_duration_s', burn_duration_s, allow_zero=True)
        dv_mps = float(np.linalg.norm(dv))
        mass_kg = self._mass_kg
        start = float(t_start)
        if self._burns:
            start = max(start, self._burns[-1].end_s)  # burns never overlap, as in the plant
        model = self._thruster_model
        if model is not None:
            model.check(dv, mass_kg)
            fuel_kg = fuel_for_delta_v_kg(mass_kg, dv_mps, model.exhaust_velocity_mps)
        else:
            fuel_kg = 0.0
        if burn_duration_s is None and model is not None:
            # The plant's burn: F / m(t), mdot = F / (Isp g0), ends when the fuel is spent.
            thrust_n, mass_flow = self.config.thrusters.max_thrust_n, model.mass_flow_kg_s
            duration = fuel_kg / mass_flow
            burn_mass = mass_kg
        else:
            duration = 0.0 if burn_duration_s is None else float(burn_duration_s)
            burn_mass = 1.0 if mass_kg is None else mass_kg
            thrust_n = dv_mps * burn_mass / duration if duration > 0.0 else math.inf
            mass_flow = 0.0
        burn = ScheduledBurn(t_cmd_s=float(t_start), start_s=start, end_s=start + duration, dv_hill=dv,
                             thrust_n=thrust_n, mass_start_kg=burn_mass, mass_flow_kg_s=mass_flow,
                             magnitude_error_at_end=mass_flow > 0.0)
        if mass_kg is not None:
            self._mass_kg = mass_kg - fuel_kg
        self._burns.append(burn)
        if self.initialized and burn.start_s < self._t:
            self._start_late_burn(burn)
        return dataclasses.replace(burn, dv_hill=dv.copy())

    # ---------------------------------------------------------------------------------------------
    # Measurements

    def update(self, t, r_hill):
        """Predict to t and update with the measured r_hill [m]; returns an UpdateResult (module doc)."""
        z = np.asarray(r_hill, dtype=float)
        if z.shape != (3,):
            raise ValueError(f'update: r_hill must have 3 components, got {r_hill!r}')
        if not (math.isfinite(t) and np.all(np.isfinite(z))):
            return self._reject('non_finite', t, f'measurement t = {t!r}, r_hill = {z.tolist()} is not finite')
        if not self.initialized:
            self.initialize(t, z)
            self.counts['initialized'] += 1
            return UpdateResult('initialized', True, float(t), math.nan, 'first measurement')
        if t < self._t:
            return self._reject('stale', t, f'measurement t = {t!r} is before the filter time {self._t!r}')
        self._advance(float(t))
        kf = self._kf
        y = z - kf.x[:3, 0]  # y = z - H x
        s = kf.P[:3, :3] + kf.R  # S = H P H' + R
        nis = float(y @ np.linalg.solve(s, y))
        if nis > self._gate:
            self._consecutive_outliers += 1
            if self._consecutive_outliers >= self.config.max_consecutive_outliers:
                return self._reset(z, nis)
            return self._reject('outlier', t, f'NIS {nis:.4g} > gate {self._gate:.4g}', nis)
        self._consecutive_outliers = 0
        # K = P H' inv(S); x = x + K y; P = (I - K H) P (I - K H)' + K R K' (Joseph form: stays
        # symmetric positive semi-definite whatever the rounding in K).
        kf.update(z)
        kf.P = 0.5 * (kf.P + kf.P.T)
        self.counts['accepted'] += 1
        return UpdateResult('accepted', True, self._t, nis, '')

    def _reject(self, kind, t, reason, nis=math.nan):
        self.counts[kind] += 1
        return UpdateResult(kind, False, float(t), nis, reason)

    def _reset(self, z, nis):
        """Lost: position from the measurement, velocity kept with at least its prior spread."""
        kf = self._kf
        p_v = kf.P[3:, 3:]
        floor = self.config.initial_velocity_sigma_mps**2
        p_v = p_v + np.diag(np.maximum(floor - np.diag(p_v), 0.0))
        p = np.zeros((6, 6))
        p[:3, :3] = self.config.position_sigma_m**2 * _I3
        p[3:, 3:] = p_v
        kf.x[:3, 0] = z
        kf.P = 0.5 * (p + p.T)
        self._consecutive_outliers = 0
        self.counts['reset'] += 1
        return UpdateResult('reset', True, self._t, nis,
                            f'{self.config.max_consecutive_outliers} consecutive outliers: position reset')

    # ---------------------------------------------------------------------------------------------
    # Prediction

    def _require_initialized(self, what):
        if not self.initialized:
            raise RuntimeError(f'{what}: the filter is not initialized (no measurement yet)')

    def _advance(self, t_target):
        """Propagate mean and covariance to t_target, splitting at burn starts and ends."""
        while True:
            for burn in self._burns:
                if not burn.started and burn.start_s <= self._t:
                    self._start_burn(burn, 0.0)
            self._burns = [b for b in self._burns if not (b.started and b.end_s <= self._t)]
            if self._t >= t_target:
                return
            t_next = t_target
            active = None
            for burn in self._burns:
                if burn.started:
                    active = burn
                    t_next = min(t_next, burn.end_s)
                else:
                    t_next = min(t_next, burn.start_s)
            self._propagate(t_next - self._t, active)
            self._t = t_next

    def _propagate(self, dt, burn):
        kf = self._kf
        phi = cw_transition_matrix(self._n, dt)  # seed 000 eq 22
        if burn is None and self.config.dynamics == 'cw':
            kf.predict(F=phi, Q=_white_accel_q(self.config.accel_psd_m2_s3, dt))  # x = Phi x; P = Phi P Phi' + Q
        else:
            x_new = self._integrate(kf.x[:, 0], self._t, dt, burn)
            kf.predict(F=phi, Q=_white_accel_q(self.config.accel_psd_m2_s3, dt))  # P = Phi P Phi' + Q
            kf.x = x_new.reshape(6, 1)
        kf.P = 0.5 * (kf.P + kf.P.T)

    def _accel_fn(self, linear):
        n = self._n
        if linear or self.config.dynamics == 'cw':
            return lambda r, v, a: cw_accel(r, v, n, a)
        radius_m = self.config.radius_m
        return lambda r, v, a: nonlinear_relative_accel(r, v, n, radius_m, a)

    def _integrate(self, x, t0, dt, burn, linear=False):
        """RK4 of the relative dynamics from (t0, x) over dt with the burn's thrust (or none)."""
        accel = self._accel_fn(linear)
        zero = (0.0, 0.0, 0.0)

        def rhs(t, y):
            a_ext = zero if burn is None else burn.accel_hill(t)
            return np.concatenate((y[3:], accel(y[:3], y[3:], a_ext)))

        steps = max(1, math.ceil(dt / self.config.max_rk4_step_s))
        h = dt / steps
        y = np.array(x, dtype=float)
        for k in range(steps):
            y = rk4_step(rhs, t0 + k * h, y, h)
        return y

    def _start_burn(self, burn, tau):
        """Burn starting (tau = 0) or found tau seconds after its start: execution-error covariance."""
        burn.started = True
        if burn.duration_s == 0.0 and tau == 0.0:
            self._kf.x[3:, 0] += burn.dv_hill  # impulse
        thr = self.config.thrusters
        if thr is None:
            return
        dv2 = float(burn.dv_hill @ burn.dv_hill)
        u = burn.direction_hill
        uu = np.outer(u, u)
        # Qdv = |dv|^2 (s_mag^2 u u' + s_dir^2 / 2 (I - u u')): the direction error is an angle
        # N(0, s_dir) about a uniformly random axis perpendicular to u.
        q_mag = dv2 * thr.magnitude_error_sigma**2 * uu
        q_dir = dv2 * 0.5 * thr.direction_error_sigma_rad**2 * (_I3 - uu)
        t_burn = burn.duration_s
        # The direction error is a constant acceleration over the burn: G = [(tau - T/2) I; I]. The
        # plant's magnitude error changes the burn's length, so it arrives at the end: G = [(tau - T) I; I].
        c_mag = tau - (t_burn if burn.magnitude_error_at_end else 0.5 * t_burn)
        g_mag = np.vstack((c_mag * _I3, _I3))
        g_dir = np.vstack(((tau - 0.5 * t_burn) * _I3, _I3))
        kf = self._kf
        kf.P = kf.P + g_mag @ q_mag @ g_mag.T + g_dir @ q_dir @ g_dir.T
        kf.P = 0.5 * (kf.P + kf.P.T)

    def _start_late_burn(self, burn):
        """A burn that began before the filter time: add the CW response to its past part."""
        tau = self._t - burn.start_s
        if burn.duration_s == 0.0:
            dx = np.concatenate((np.zeros(3), burn.dv_hill))
            dx = cw_transition_matrix(self._n, tau) @ dx
        else:
            t_burn = min(tau, burn.duration_s)
            dx = self._integrate(np.zeros(6), burn.start_s, t_burn, burn, linear=True)
            dx = cw_transition_matrix(self._n, tau - t_burn) @ dx
        self._kf.x[:, 0] += dx
        self._start_burn(burn, tau)
        # An impulse was applied through dx; _start_burn adds only its covariance (tau > 0).
