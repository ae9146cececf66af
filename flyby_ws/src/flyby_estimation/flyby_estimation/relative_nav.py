"""Chaser relative navigation: a Kalman filter on the chaser's relative state in the hill frame.

State x = [r_hill (3) [m]; v_hill (3) [m/s]], v_hill the velocity relative to the rotating hill frame
(seed 000 section 3: x along-track, y orbit anti-normal, z toward Earth's centre; the frame turns at
[0, -n, 0]). Built on ``filterpy.kalman.KalmanFilter`` (linear KF; with ``dynamics='nonlinear'`` an
EKF in the sense of seed 004 section 2.2: the mean follows the nonlinear model, the covariance its
linearization). The verbs and outcomes are those of ``filter_interface``: ``update`` returns an
``UpdateResult``, ``propagate_to`` moves the filter time, ``predict`` leaves the filter unchanged.

Process model (time update):
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
executes it, with the burn chain of ``flyby_sim.dynamics.propulsion`` that the plant's thrusters use:
the commands not yet started wait in order of (stamp, command number) and are re-chained whenever one
is added, each a burn at max thrust F in the commanded direction starting at its stamp or when the burn
before it ends, after the last burn already started. Thrust acceleration F / m(t) with the mass falling
at F / (Isp g0); duration from the rocket equation so that the burn delivers exactly the commanded
delta-v; the mass is tracked over the maneuvers. Without thruster data a burn of given duration has
constant acceleration dv / T; duration 0 is an impulse at its start.
The residual left is only the unknown execution error; it enters the covariance when the burn starts
as P += G Qdv G' with
    Qdv = |dv|^2 (s_mag^2 u u' + s_dir^2 / 2 (I - u u')),   G = [(tau - T/2) I; I],
u the command direction, T the burn duration, tau the time since the burn start (0 for a burn
known in time). The thrusters' error is a constant acceleration dv_err / T over the burn, which at
the burn end is [dv_err T / 2; dv_err]: injecting G dv_err at the start and coasting gives exactly
that at the end (during the burn the injected velocity spread is conservative).

A burn added with ``execution_error=False`` injects nothing: its error is measured instead (the
accelerometer, ``add_thrust_error``: the measured thrust delta-v over an interval less the modelled one,
a constant acceleration error over the interval, x += [dv_err T / 2; dv_err] and P += G C G' with
G = [T/2 I; I] and C the measurement's covariance, both carried by the CW transition from the interval's
end to the filter time).

A command whose burn starts before the filter time ("late" for the filter) is applied retroactively:
the CW response to the part of the burn already past is added to the mean. Measurements already
processed in between were not explained by the burn; the gate and the outlier reset below cover
what that leaves. (The plant, which hears the command at its own time, starts such a burn then: the
filter's request time is the stamp, the plant's the later of stamp and arrival.)

Measurements (``update``): r_hill with per-axis noise sigma, H = [I 0]. The normalized innovation
squared NIS = y' S^-1 y (y = z - H x, S = H P H' + R) is gated against the chi-square(3) quantile of
``gate_probability``. Outcomes: 'initialized', 'accepted', and the rejections 'non_finite' (not a
finite stamp and 3 finite numbers), 'stale' (t before the filter time), 'outlier' (NIS above the
gate), counted in ``counts``. A run of ``max_consecutive_outliers`` outliers in a row whose innovations
agree with each other (filter_interface's restart rule: a quadratic in time per hill axis within the noise,
as a lost filter's are, and random outliers never) makes the filter assume it is lost and restart from the
run's last measurement: the position is set to it, the velocity kept with at least its prior spread (kind
'reset'). The covariance update is Joseph form (filterpy's arithmetic for H = [I 0],
``filter_interface.kalman_update_first_three``), followed by explicit symmetrization.

Initialization: from the first finite measurement, r = z, P_r = sigma^2 I, v = 0 with
P_v = initial_velocity_sigma_mps^2 I (the schema's 0.1 m/s: the chaser holds station before the approach),
or explicitly with ``initialize``. The initial state includes the maneuvers whose burns started before
it: they are taken as done (a burn still going continues from there).

No rclpy. SI units throughout.
"""

import copy
import dataclasses
import math
from typing import NamedTuple

import numpy as np
from filterpy.kalman import KalmanFilter

from flyby_estimation.filter_interface import FilterBase, UpdateResult, check_run_length, kalman_update_first_three
from flyby_msgs_py.stamped import put_bounded
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.orbital import cw_coast, cw_transition_matrix, relative_accel_components, rk4_step
from flyby_sim.dynamics.propulsion import (
    BurnRequest,
    ManeuverRejected,
    ThrusterConfig,
    chain_burns,
    check_delta_v,
    fuel_for_delta_v_kg,
    insert_request,
)

DYNAMICS = ('cw', 'nonlinear')
_I3 = np.eye(3)
MAX_TRANSITIONS = 64  # cached (Phi, Q) pairs, one per time step seen

__all__ = ['DYNAMICS', 'ManeuverRejected', 'NavState', 'RelativeNavConfig',
           'RelativeNavFilter', 'ScheduledBurn']


@dataclasses.dataclass(frozen=True)
class RelativeNavConfig:
    """Filter parameters; validated on construction (ValueError names the field).

    The fields up to gate_probability are the scenario's (``params.RelativeNavParams.config``: their defaults are
    the scenario schema's); the rest are the filter's own, with defaults.
    max_consecutive_outliers: N, the run of consecutive outliers whose agreement restarts the filter from its
    last measurement (module doc, filter_interface's restart rule); N >= MIN_RUN_SAMPLES.
    """

    mean_motion_rad_s: float  # n of the target orbit
    position_sigma_m: float  # measurement noise, 1-sigma per axis
    accel_psd_m2_s3: float  # q: white-acceleration spectral density (estimation.accel_psd_m2_s3)
    initial_velocity_sigma_mps: float  # velocity prior, 1-sigma per axis (estimation.initial_velocity_sigma_mps)
    gate_probability: float  # chi2(3) gate on the NIS (estimation.gate_probability)
    max_consecutive_outliers: int = 20  # the run tested for agreement (2 s at 10 Hz)
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
        check_run_length(self.max_consecutive_outliers)
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


class NavState(NamedTuple):
    """Filter output at time t: r_hill [m], v_hill [m/s], covariance 6x6 of [r; v] (copies)."""

    t: float
    r_hill: np.ndarray
    v_hill: np.ndarray
    covariance: np.ndarray


@dataclasses.dataclass(frozen=True, eq=False)
class ScheduledBurn:
    """A maneuver as the filter models it (times sim time [s], hill axes).

    The plant's burn (with thruster data) is the ``propulsion.Burn`` of the chain, thrust F with mass
    flow F / (Isp g0); a burn of given duration T has thrust |dv| m / T and no mass flow (constant
    acceleration), an impulse infinite thrust and T = 0.
    """

    seq: int  # command number, counting the maneuvers added from 0 (as the plant numbers them)
    t_cmd_s: float  # the command's stamp
    start_s: float
    end_s: float  # == start_s for an impulse
    dv_hill: np.ndarray  # commanded delta-v [m/s]
    thrust_n: float
    mass_start_kg: float  # for the thrust acceleration: 1 without mass data
    mass_flow_kg_s: float
    mass_end_kg: float  # None without mass data
    magnitude_error_at_end: bool  # the plant's burn: a magnitude error lengthens or shortens it

    @property
    def duration_s(self):
        return self.end_s - self.start_s

    @property
    def direction_hill(self):
        return self.dv_hill / np.linalg.norm(self.dv_hill)

    def accel_hill(self, t):
        """Commanded thrust acceleration [m/s^2] at time t inside the burn."""
        return self.direction_hill * (self.thrust_n / (self.mass_start_kg - self.mass_flow_kg_s * (t - self.start_s)))


def white_accel_q(q, dt):
    """Discrete process noise of white acceleration with density q over dt (double-integrator form)."""
    q11, q12, q22 = q * dt**3 / 3.0, q * dt**2 / 2.0, q * dt
    return np.array(((q11, 0.0, 0.0, q12, 0.0, 0.0),  # [[q11 I, q12 I], [q12 I, q22 I]] in one call
                     (0.0, q11, 0.0, 0.0, q12, 0.0),
                     (0.0, 0.0, q11, 0.0, 0.0, q12),
                     (q12, 0.0, 0.0, q22, 0.0, 0.0),
                     (0.0, q12, 0.0, 0.0, q22, 0.0),
                     (0.0, 0.0, q12, 0.0, 0.0, q22)))


class RelativeNavFilter(FilterBase):
    """Kalman filter for the chaser's relative state (module doc); a ``filter_interface.EstimationFilter``.

    Not thread-safe.
    """

    def __init__(self, config):
        if not isinstance(config, RelativeNavConfig):
            raise ValueError(f'config must be a RelativeNavConfig, got {config!r}')
        super().__init__(config.gate_probability, config.max_consecutive_outliers, config.position_sigma_m, ('hill',))
        self.config = config
        self._n = config.mean_motion_rad_s
        self._kf = KalmanFilter(dim_x=6, dim_z=3)  # x and P, and predict; H = [I 0] in the update
        self._r = config.position_sigma_m**2 * _I3
        self._requests = []  # propulsion.BurnRequest of the maneuvers not started, in burn order
        self._fixed_duration_s = {}  # seq -> the burn_duration_s given to add_maneuver (absent: the plant's burn)
        self._pending = []  # ScheduledBurn of each request, chained after the last started burn
        self._active = None  # the started burn, until the filter time passes its end
        self._chain_end = (-math.inf, config.chaser_mass_kg)  # end time and mass after the last started burn
        self._seq = 0
        self._measured = set()  # seq of the requests whose execution error is measured, not injected
        # dt [s] -> (Phi, Q): the measurement interval takes a few values (the stamps' rounding), so few entries
        self._transitions = {}

    # ---------------------------------------------------------------------------------------------
    # State

    def initialize(self, t, r_hill, v_hill=(0.0, 0.0, 0.0), covariance=None):
        """Set the state at time t; covariance defaults to diag(sigma_pos^2 I, sigma_v0^2 I).

        The state given includes the burns started before t (module doc).
        """
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
        self._rejected.clear()
        while self._pending and self._pending[0].start_s < self._t:
            self._take_next_burn()
        self._retire_active()

    def state(self):
        """NavState at the filter time."""
        self._require_initialized('state')
        x = self._kf.x[:, 0]
        return NavState(self._t, x[:3].copy(), x[3:].copy(), self._kf.P.copy())

    def propagate_to(self, t):
        """Time update to t >= the filter time [s], in place (no measurement).

        Measurements stamped before t are then stale; ``predict`` leaves the filter unchanged.
        """
        self._require_initialized('propagate_to')
        if not math.isfinite(t):
            raise ValueError(f'propagate_to: t = {t!r} s is not finite')
        if t < self._t:
            raise ValueError(f'propagate_to: t = {t!r} s is before the filter time {self._t!r} s')
        self._advance(float(t))

    def predict(self, t):
        """NavState predicted to t >= the filter time [s], leaving the filter unchanged."""
        ahead = copy.deepcopy(self)
        ahead.propagate_to(t)
        return ahead.state()

    @property
    def burns(self):
        """Maneuvers scheduled and not yet finished, in burn order (ScheduledBurn, copies)."""
        active = [] if self._active is None else [self._active]
        return [dataclasses.replace(b, dv_hill=b.dv_hill.copy()) for b in active + self._pending]

    @property
    def mass_kg(self):
        """Modelled chaser mass after all maneuvers added so far [kg] (None without mass data)."""
        return self._pending[-1].mass_end_kg if self._pending else self._chain_end[1]

    # ---------------------------------------------------------------------------------------------
    # Inputs

    def add_maneuver(self, t_cmd, dv_hill, burn_duration_s=None, execution_error=True):
        """Add a commanded maneuver: delta-v dv_hill [m/s] stamped t_cmd [s]; returns its ScheduledBurn
        as scheduled now (a later command stamped earlier shifts it, as in the plant).

        burn_duration_s None: the plant's finite burn from the thruster data (module doc), or an
        impulse without thruster data; a number: a constant-acceleration burn of that duration
        (0 = impulse). Raises ManeuverRejected for a delta-v the thrusters reject
        (``propulsion.check_delta_v`` from the mass after the burns started, as the plant would: the
        maneuver then never happens) and ValueError for a malformed input. execution_error False: the
        thrusters' error is not injected into the covariance (it is measured, ``add_thrust_error``).
        """
        if not math.isfinite(t_cmd):
            raise ValueError(f'add_maneuver: t_cmd = {t_cmd!r} is not finite')
        dv = np.asarray(dv_hill, dtype=float)
        if dv.shape != (3,) or not np.all(np.isfinite(dv)) or not np.any(dv):
            raise ValueError(f'add_maneuver: dv_hill must be 3 finite numbers, not all zero, got {dv_hill!r}')
        if burn_duration_s is not None:
            require_positive('burn_duration_s', burn_duration_s, allow_zero=True)
        if self.config.thrusters is not None:
            check_delta_v(dv, self._chain_end[1], self.config.thrusters)
        seq = self._seq
        self._seq += 1
        dv_tuple = tuple(dv.tolist())
        # Requested at the stamp, even when it has passed: the burn is then applied retroactively.
        self._requests = insert_request(self._requests, BurnRequest(float(t_cmd), seq, float(t_cmd), dv_tuple,
                                                                    dv_tuple))
        if burn_duration_s is not None:
            self._fixed_duration_s[seq] = float(burn_duration_s)
        if not execution_error:
            self._measured.add(seq)
        self._rechain()
        added = next(b for b in self._pending if b.seq == seq)
        if self.initialized:
            while self._pending and self._pending[0].start_s < self._t:
                self._start_next_burn()
            self._retire_active()
        return dataclasses.replace(added, dv_hill=added.dv_hill.copy())

    def _rechain(self):
        """Schedule the requests after the last started burn, in burn order (propulsion.chain_burns)."""
        prev_end_s, mass_kg = self._chain_end
        thrusters = self.config.thrusters
        pending = []
        for request in self._requests:
            dv = np.array(request.dv_hill)
            duration = self._fixed_duration_s.get(request.seq)
            if duration is None and thrusters is not None:
                # The plant's burn: F / m(t), mdot = F / (Isp g0), ends when the fuel is spent.
                (burn,) = chain_burns([request], prev_end_s, mass_kg, thrusters)
                scheduled = ScheduledBurn(
                    seq=request.seq, t_cmd_s=request.t_cmd_s, start_s=burn.start_s, end_s=burn.end_s, dv_hill=dv,
                    thrust_n=thrusters.max_thrust_n, mass_start_kg=mass_kg, mass_flow_kg_s=thrusters.mass_flow_kg_s,
                    mass_end_kg=burn.mass_end_kg, magnitude_error_at_end=True)
            else:
                duration = 0.0 if duration is None else duration  # without thruster data: an impulse
                start = max(request.request_s, prev_end_s)  # burns never overlap, as in the plant
                dv_mps = float(np.linalg.norm(dv))
                accel_mass_kg = 1.0 if mass_kg is None else mass_kg
                fuel_kg = 0.0 if thrusters is None else fuel_for_delta_v_kg(mass_kg, dv_mps,
                                                                            thrusters.exhaust_velocity_mps)
                scheduled = ScheduledBurn(
                    seq=request.seq, t_cmd_s=request.t_cmd_s, start_s=start, end_s=start + duration, dv_hill=dv,
                    thrust_n=dv_mps * accel_mass_kg / duration if duration > 0.0 else math.inf,
                    mass_start_kg=accel_mass_kg, mass_flow_kg_s=0.0,
                    mass_end_kg=None if mass_kg is None else mass_kg - fuel_kg, magnitude_error_at_end=False)
            pending.append(scheduled)
            prev_end_s, mass_kg = scheduled.end_s, scheduled.mass_end_kg
        self._pending = pending

    def _take_next_burn(self):
        """Move the first pending burn to the started one (the chain after it is unchanged); returns it and whether
        its execution error is measured (not injected)."""
        burn = self._pending.pop(0)
        self._requests.pop(0)
        self._fixed_duration_s.pop(burn.seq, None)
        measured = burn.seq in self._measured
        self._measured.discard(burn.seq)
        self._active = burn
        self._chain_end = (burn.end_s, burn.mass_end_kg)
        return burn, measured

    def _retire_active(self):
        if self._active is not None and self._active.end_s <= self._t:
            self._active = None

    def add_thrust_error(self, t_start, t_end, dv_error_hill, covariance):
        """A measured thrust delta-v error dv_error_hill [m/s] over [t_start, t_end] (the accelerometer's
        delta-v less the modelled one) with its 3x3 covariance [m^2/s^2]: a constant acceleration error over
        the interval (module doc). The filter time must be at or after t_end."""
        self._require_initialized('add_thrust_error')
        dv = np.asarray(dv_error_hill, dtype=float)
        cov = np.asarray(covariance, dtype=float)
        if not (math.isfinite(t_start) and math.isfinite(t_end) and t_start <= t_end and dv.shape == (3,)
                and np.all(np.isfinite(dv)) and cov.shape == (3, 3) and np.all(np.isfinite(cov))):
            raise ValueError(f'add_thrust_error: interval [{t_start!r}, {t_end!r}] s, dv_error_hill {dv_error_hill!r} '
                             f'and a finite 3x3 covariance expected')
        if t_end > self._t:
            raise ValueError(f'add_thrust_error: the interval ends at {t_end!r} s, after the filter time {self._t!r} s')
        g = np.vstack((0.5 * (t_end - t_start) * _I3, _I3))  # [T/2 I; I]
        if self._t > t_end:
            g = cw_transition_matrix(self._n, self._t - t_end) @ g  # seed 000 eq 22
        kf = self._kf
        kf.x[:, 0] += g @ dv
        kf.P = kf.P + g @ cov @ g.T
        kf.P = 0.5 * (kf.P + kf.P.T)

    # ---------------------------------------------------------------------------------------------
    # Measurements

    def update(self, t, r_hill):
        """Propagate to t and update with the measured r_hill [m]; returns an UpdateResult (module doc)."""
        z = np.asarray(r_hill, dtype=float)
        if not (math.isfinite(t) and z.shape == (3,) and all(map(math.isfinite, z.tolist()))):
            return self._outcome('non_finite', t, reason=f'measurement t = {t!r} s, r_hill = {r_hill!r} is not a '
                                                         f'finite stamp and 3 finite numbers')
        if not self.initialized:
            self.initialize(t, z)
            return self._outcome('initialized', t)
        if t < self._t:
            return self._outcome('stale', t, reason=f'measurement t = {t!r} s is before the filter time {self._t!r} s')
        self._advance(float(t))
        kf = self._kf
        y = z - kf.x[:3, 0]  # y = z - H x
        # NIS = y' S^-1 y, S = H P H' + R; K = P H' S^-1; x = x + K y; P = (I - K H) P (I - K H)' + K R K'
        # (Joseph form: stays symmetric positive semi-definite whatever the rounding in K).
        nis, x, p = kalman_update_first_three(kf.x, kf.P, y, self._r)
        verdict = self._gate_verdict(nis, t, lambda: (y,))
        if verdict != 'pass':
            if verdict == 'reset':
                self._reset(z)
                return self._outcome('reset', t, nis, f'{self.config.max_consecutive_outliers} consecutive '
                                                      f'outliers {self._rejected.agreement}, the last NIS '
                                                      f'{nis:.4g} > gate {self._gate:.4g}: position reset to the '
                                                      f'measurement', y)
            return self._outcome('outlier', t, nis, f'NIS {nis:.4g} > gate {self._gate:.4g} (|y| = '
                                                    f'{float(np.linalg.norm(y)):.4g} m)', y)
        kf.x = x
        kf.P = 0.5 * (p + p.T)
        return self._outcome('accepted', t, nis, '', y)

    def _outcome(self, kind, t, nis=math.nan, reason='', innovation=None):
        self.counts[kind] += 1
        return UpdateResult(kind, float(t), nis, reason, innovation)

    def _reset(self, z):
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
        self._rejected.clear()

    # ---------------------------------------------------------------------------------------------
    # Time update

    def _require_initialized(self, what):
        if not self.initialized:
            raise RuntimeError(f'{what}: the filter is not initialized (no measurement yet)')

    def _advance(self, t_target):
        """Propagate mean and covariance to t_target, splitting at burn starts and ends."""
        while True:
            self._retire_active()
            if self._active is None and self._pending and self._pending[0].start_s <= self._t:
                self._start_next_burn()
                continue
            if self._t >= t_target:
                return
            if self._active is not None:
                t_next = min(t_target, self._active.end_s)
            else:
                t_next = min(t_target, self._pending[0].start_s) if self._pending else t_target
            self._propagate(t_next - self._t, self._active)
            self._t = t_next

    def _propagate(self, dt, burn):
        kf = self._kf
        phi, q = self._transition(dt)
        if burn is None and self.config.dynamics == 'cw':
            kf.predict(F=phi, Q=q)  # x = Phi x; P = Phi P Phi' + Q
        else:
            x_new = self._integrate(kf.x[:, 0], self._t, dt, burn)
            kf.predict(F=phi, Q=q)  # P = Phi P Phi' + Q
            kf.x = x_new.reshape(6, 1)
        kf.P = 0.5 * (kf.P + kf.P.T)

    def _transition(self, dt):
        """(Phi(dt), Q(dt)) of the time update, kept for the later calls with the same dt (read only)."""
        phi_q = self._transitions.get(dt)
        if phi_q is None:
            phi_q = (cw_transition_matrix(self._n, dt),  # seed 000 eq 22
                     white_accel_q(self.config.accel_psd_m2_s3, dt))
            put_bounded(self._transitions, dt, phi_q, MAX_TRANSITIONS)
        return phi_q

    def _accel_fn(self, linear):
        return relative_accel_components('cw' if linear else self.config.dynamics, self._n, self.config.radius_m)

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

    def _start_next_burn(self):
        """Start the first pending burn, due at or before the filter time.

        Mean: an impulse adds its dv; a burn that began tau > 0 s before the filter time (late for the
        filter) adds the CW response to its past part. Covariance: the execution error (module doc).
        """
        burn, measured = self._take_next_burn()
        tau = self._t - burn.start_s
        kf = self._kf
        if burn.duration_s == 0.0:
            kf.x[:, 0] += cw_coast(np.zeros(3), burn.dv_hill, tau, self._n)  # eq 22
        elif tau > 0.0:
            t_burn = min(tau, burn.duration_s)
            dx = self._integrate(np.zeros(6), burn.start_s, t_burn, burn, linear=True)
            kf.x[:, 0] += cw_transition_matrix(self._n, tau - t_burn) @ dx
        thr = self.config.thrusters
        if thr is None or measured:
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
        kf.P = kf.P + g_mag @ q_mag @ g_mag.T + g_dir @ q_dir @ g_dir.T  # P += G Qdv G'
        kf.P = 0.5 * (kf.P + kf.P.T)
