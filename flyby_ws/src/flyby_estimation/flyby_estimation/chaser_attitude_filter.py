"""Chaser attitude filter: a multiplicative EKF of the chaser's own attitude and gyro bias (no ROS).

Estimates q_eci_from_body of ``chaser_body`` and the gyro bias from the chaser IMU
(``/sensors/chaser/imu``, DESIGN §10): the gyro drives the time update, the star
tracker's q_hill_from_body is the measurement. The body rate is not a state: it is the gyro minus the
estimated bias (the usual gyro-driven attitude filter, Lefferts, Markley and Shuster 1982, ref. 3 of
seed 004; Markley and Crassidis, "Fundamentals of Spacecraft Attitude Determination and Control",
2014, §6.2, "M&C" below; the same filter in Crassidis and Junkins, "Optimal Estimation of Dynamic
Systems", 2nd ed., §7.2). The formulas are written out here in full; their equation numbers in the
books could not be checked on this machine and are not quoted.

Conventions: quaternions (x, y, z, w), scalar last (``flyby_sim.dynamics.rotation``);
``q_a_from_b`` rotates b vectors into a. Reference attitude q_eci_from_body; error state
x = [dtheta_body, dbias_body] (6) with q_true = q_ref * exp(dtheta_body) (a rotation vector in body
axes, as in the target filter) and bias_true = bias_ref + dbias_body [rad/s]. ``omega_body`` is the
chaser's inertial angular velocity in body axes, the rate the gyro measures.

Sensor model (the plant's; sigma_g per sample, not a density):

    gyro, every 1/rate_hz:  omega_meas_k = omega_body(t_k) + b_k + sigma_g n_k,
                            b_k = b_(k-1) + sigma_bw sqrt(dt) m_k,  b_0 ~ N(0, sigma_b0^2 I)
    star tracker:           q_meas = q_hill_from_body * dq,  dq = exp(sigma_st N(0, I3))   (body-frame error)

Time update (``on_gyro``), from the filter time to the stamp of the new gyro sample:

* **Mean.** The rate is the linear interpolant of the two gyro samples that bound the step, less the
  bias estimate; the body turns through the rotation vector of its second-order Magnus expansion
  (Bortz 1971: trapezoid plus coning term),

      theta = h/2 (w_a + w_b) + h^2/12 (w_a x w_b),   q <- q * exp(theta)        seed 000 eq 4 over h

  which is exact to O(h^3 d2omega/dt2). Holding the earlier sample instead ("zero-order hold", the
  ``gyro_interpolation='hold'`` option) lags the rate by h/2: for a tumbling or slewing chaser
  (|domega/dt| ~ 5e-4 rad/s^2 for seed 001's servicer at 3 deg/s) that is an error rate of ~2.5e-5 rad/s,
  a false bias 250 times the bias walk over 100 s, which the filter would take for a bias and be
  inconsistent (docs/estimation.md). The averaging needs the sample at the end of the step,
  which is the one that triggers it, so it costs no latency.
* **Transition** of the error over the step, at the step's mean rate w = theta / h held constant
  (M&C §6.2, closed form; a = |theta|):

      Phi_11 = exp(-[w x] h) = I - sin(a)/a [theta x] + (1 - cos a)/a^2 [theta x]^2
      Phi_12 = h ((1 - cos a)/a^2 [theta x] - I - (a - sin a)/a^3 [theta x]^2),  Phi_21 = 0, Phi_22 = I

  i.e. d(dtheta)/dt = -[w x] dtheta - dbias - eta_v, d(dbias)/dt = eta_u.
* **Process noise** of Farrenkopf's gyro model (Farrenkopf 1978; M&C §6.2) over a step of h seconds,

      Qd = [[(sigma_v^2 h + sigma_u^2 h^3 / 3) I, -(sigma_u^2 h^2 / 2) I], [-(sigma_u^2 h^2 / 2) I, sigma_u^2 h I]]

  with the plant's per-sample noise as an angle random walk sigma_v^2 = sigma_g^2 / rate_hz (a sample's
  noise sigma_g held for one sample period turns the attitude by sigma_g / rate_hz: the same variance
  per step, and steps split at a star-tracker stamp add up to it) and sigma_u = sigma_bw. Two
  approximations, both far below the other terms: the averaged samples make consecutive steps'
  gyro noise correlated (each sample enters two steps with weight 1/2; the variance over N steps is
  (N - 1/2) sigma_g^2 / rate_hz^2 in the truth, N in Qd); the bias jumps at the samples rather than
  drifting (1/4 instead of 1/3 in the h^3 term, 1e-17 rad^2 per step at the defaults); the rotation
  inside one step is left out of the bias-walk terms (O(|w| h) ~ 5e-3 relative of those).
* P <- Phi P Phi' + Qd.

Measurement update (``on_star_tracker``, also ``update``): z = q_hill_from_body at stamp t, taken to
inertial with q_eci_from_hill(t, n) (``orbital.q_eci_from_body``: the hill frame turns at n about
ECI +z); innovation nu = log(q_ref^-1 * q_meas) (``filter_interface.attitude_innovation``), H = [I 0],
R = sigma_st^2 I (the sensor model exactly); gated, Joseph-form update
(``filter_interface.kalman_update_first_three``); then Markley's reset
(``filter_interface.fold_attitude_error``: q <- q * exp(dtheta), P <- G P G' with
G = I - 1/2 [dtheta x] on the attitude block) and bias += dbias.

Initialization: the first valid star-tracker sample sets the attitude (sigma ``initial_attitude_sigma_rad``,
default the star tracker's) and the bias starts at 0 with sigma_b0 per axis. A run of
``max_consecutive_outliers`` outliers in a row that agree with each other (filter_interface's restart rule:
a smooth error in the body or the inertial frame; a reference off by a fixed rotation, as after a gyro
glitch, is off by a constant in the inertial frame) restarts the attitude from the run's last sample (kind
'reset'); the bias estimate is kept, its variance raised to at least sigma_b0^2. Random outliers do not.
A gap in the gyro longer than the health monitor's staleness (``health.STALE_PERIODS`` sample periods) leaves the
body's turn over it unmeasured, which neither the interpolant nor Farrenkopf's noise stands for (a 30 s IMU
dropout while the chaser's control turns it): the next star-tracker sample sets the attitude again, as the first
one did (kind 'initialized'), the bias and its covariance kept.

Outcomes are those of ``filter_interface`` (``UpdateResult``): star-tracker samples are counted in
``counts`` ('initialized', 'accepted', 'reset', 'non_finite', 'non_unit', 'stale', 'outlier'); gyro
samples in ``gyro_counts`` ('accepted', 'non_finite', 'stale': a gyro sample has no innovation to gate).
"""

import dataclasses
import math

import numpy as np
from scipy.linalg import solve_discrete_are

from flyby_estimation.filter_interface import (
    ATTITUDE_FRAMES,
    FilterBase,
    attitude_errors,
    attitude_innovation,
    check_run_length,
    fold_attitude_error,
    kalman_update_first_three,
    new_counts,
)
from flyby_estimation.health import STALE_PERIODS
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.orbital import q_eci_from_body, q_hill_from_body
from flyby_sim.dynamics.rotation import quat_from_rotation_vector, quat_multiply, quat_normalize, quat_to_matrix

GYRO_INTERPOLATIONS = ('linear', 'hold')
_ZERO_STATE = np.zeros((6, 1))  # the error state between updates (reset after each)
_SMALL_ANGLE_RAD = 1e-2  # below it the coefficients of Phi by their Taylor series (truncation < 1e-23)


@dataclasses.dataclass(frozen=True)
class ChaserAttitudeFilterConfig:
    """Parameters of ChaserAttitudeFilter (validated; ValueError names the field).

    The sensor fields and the gate are the scenario's ``sensors.chaser_imu`` keys in SI units and
    ``estimation.gate_probability`` (``params.ChaserAttitudeFilterParams.config``: their defaults are the scenario
    schema's); the rest are the filter's own, with defaults.

    Attributes:
        mean_motion_rad_s: orbital mean motion n [rad/s] of the hill frame.
        rate_hz: IMU (gyro) sample rate [Hz] (``rate_hz``); sets the gyro noise density
            sigma_g^2 / rate_hz and the steady state.
        star_tracker_rate_hz: star-tracker rate [Hz] (``star_tracker_rate_hz``); used only by
            ``steady_state`` (the filter fuses a sample whenever one comes).
        star_tracker_sigma_rad: star-tracker noise, 1 sigma per body axis [rad]
            (``star_tracker_sigma_deg``); > 0 (the scenario allows a perfect star tracker, 0, which the
            filter cannot weigh: give it a floor as an override).
        gyro_noise_sigma_rad_s: gyro white noise per sample [rad/s] (``gyro_noise_sigma_rad_s``).
        gyro_bias_sigma_rad_s: 1 sigma per axis of the initial bias [rad/s] (``gyro_bias_sigma_rad_s``).
        gyro_bias_walk_rad_s_sqrt_s: bias random walk [rad/s/sqrt(s)] (``gyro_bias_walk_rad_s_sqrt_s``).
        gate_probability: chi2(3) probability of the innovation gate (0.9999: d2 < 21.1).
        max_consecutive_outliers: N, the run of consecutive star-tracker outliers whose agreement restarts the
            attitude from its last sample (filter_interface's restart rule); N >= MIN_RUN_SAMPLES.
        initial_attitude_sigma_rad: attitude sigma per axis at initialization [rad]; None (default) = the
            star tracker's.
        norm_tolerance: star-tracker samples with |norm - 1| above this are rejected as 'non_unit'.
        gyro_interpolation: 'linear' (default: the rate between two samples is their linear
            interpolant) or 'hold' (the earlier sample held over the step); module doc.
    """

    mean_motion_rad_s: float
    rate_hz: float
    star_tracker_rate_hz: float
    star_tracker_sigma_rad: float
    gyro_noise_sigma_rad_s: float
    gyro_bias_sigma_rad_s: float
    gyro_bias_walk_rad_s_sqrt_s: float
    gate_probability: float
    max_consecutive_outliers: int = 20
    initial_attitude_sigma_rad: float | None = None
    norm_tolerance: float = 1e-3
    gyro_interpolation: str = 'linear'

    def __post_init__(self):
        for name in ('mean_motion_rad_s', 'rate_hz', 'star_tracker_rate_hz', 'star_tracker_sigma_rad',
                     'norm_tolerance'):
            require_positive(name, getattr(self, name))
        for name in ('gyro_noise_sigma_rad_s', 'gyro_bias_sigma_rad_s', 'gyro_bias_walk_rad_s_sqrt_s'):
            require_positive(name, getattr(self, name), allow_zero=True)
        if self.initial_attitude_sigma_rad is not None:
            require_positive('initial_attitude_sigma_rad', self.initial_attitude_sigma_rad)
        if not 0.0 < self.gate_probability < 1.0:
            raise ValueError(f'gate_probability must be in (0, 1), got {self.gate_probability}')
        check_run_length(self.max_consecutive_outliers)
        if self.gyro_interpolation not in GYRO_INTERPOLATIONS:
            raise ValueError(f'gyro_interpolation must be one of {GYRO_INTERPOLATIONS}, '
                             f'got {self.gyro_interpolation!r}')

    @property
    def attitude_sigma0_rad(self):
        """Attitude sigma per axis at initialization [rad]."""
        s = self.initial_attitude_sigma_rad
        return self.star_tracker_sigma_rad if s is None else s


@dataclasses.dataclass(frozen=True, eq=False)
class ChaserAttitudeEstimate:
    """The chaser's estimated attitude and rate at one time (arrays are the estimate's own).

    Attributes:
        t: time [s].
        q_eci_from_body, q_hill_from_body: chaser_body attitude (x, y, z, w) in ECI and in hill at t.
        omega_body: inertial angular velocity in body axes [rad/s]: the latest gyro sample less the
            estimated bias (twist.angular of ``/estimation/chaser/odom``, child frame chaser_body).
        bias_rad_s: estimated gyro bias [rad/s], body axes.
        covariance: 6x6 covariance of [dtheta_body, dbias_body] [rad^2, rad^2/s, rad^2/s^2].
        gyro_noise_sigma_rad_s: the gyro's white noise per sample (for rate_covariance).
    """

    t: float
    q_eci_from_body: np.ndarray
    q_hill_from_body: np.ndarray
    omega_body: np.ndarray
    bias_rad_s: np.ndarray
    covariance: np.ndarray
    gyro_noise_sigma_rad_s: float

    @property
    def attitude_covariance_hill(self):
        """3x3 covariance of the attitude error as a rotation about hill axes, C_hill_from_body P_thth C'
        (the orientation block of a pose in frame hill, e.g. ``/estimation/chaser/odom``)."""
        c = quat_to_matrix(self.q_hill_from_body)
        return c @ self.covariance[:3, :3] @ c.T

    @property
    def rate_covariance(self):
        """3x3 covariance of omega_body's error, sigma_g^2 I + P_bias [rad^2/s^2] (body axes: the sample's own
        noise and the bias error; their correlation with the attitude is left out). The twist's angular block."""
        return self.gyro_noise_sigma_rad_s ** 2 * np.eye(3) + self.covariance[3:, 3:]

    @property
    def attitude_sigma_rad(self):
        """1-sigma attitude error per body axis [rad] (3,)."""
        return np.sqrt(np.diag(self.covariance)[:3])


def step_rotation_vector(omega_a, omega_b, h):
    """Rotation vector [rad] of the body over h [s] when its body rate goes linearly from omega_a to omega_b
    [rad/s]: q(t + h) = q(t) * exp(theta), theta = h/2 (omega_a + omega_b) + h^2/12 (omega_a x omega_b).

    The second-order Magnus expansion of seed 000 eq 4 (Bortz 1971: the trapezoid plus the coning
    term), exact for a constant rate and to O(h^3) otherwise.
    """
    ax, ay, az = omega_a
    bx, by, bz = omega_b
    c = h * h / 12.0
    return (0.5 * h * (ax + bx) + c * (ay * bz - az * by),
            0.5 * h * (ay + by) + c * (az * bx - ax * bz),
            0.5 * h * (az + bz) + c * (ax * by - ay * bx))


def error_transition(theta, h):
    """Phi (6x6) of the error [dtheta_body, dbias_body] over a step of h [s] turning the body by theta [rad]
    at the constant rate theta / h (M&C §6.2, closed form; module doc).

    Written with [theta x]^2 = theta theta' - a^2 I on Python floats (one array built, no matrix products).
    """
    tx, ty, tz = theta
    a2 = tx * tx + ty * ty + tz * tz
    if a2 < _SMALL_ANGLE_RAD ** 2:  # Taylor series of sin(a)/a, (1 - cos a)/a^2, (a - sin a)/a^3 to a^6
        a4 = a2 * a2
        s1 = 1.0 - a2 / 6.0 + a4 / 120.0 - a4 * a2 / 5040.0
        c1 = 0.5 - a2 / 24.0 + a4 / 720.0 - a4 * a2 / 40320.0
        c2 = 1.0 / 6.0 - a2 / 120.0 + a4 / 5040.0 - a4 * a2 / 362880.0
    else:
        a = math.sqrt(a2)
        sin_half = math.sin(0.5 * a)
        s1, c1, c2 = math.sin(a) / a, 2.0 * sin_half * sin_half / a2, (a - math.sin(a)) / (a2 * a)
    # Phi_11 = I - s1 [theta x] + c1 [theta x]^2;  Phi_12 = h (c1 [theta x] - I - c2 [theta x]^2)
    d11 = 1.0 - c1 * a2
    d12 = h * (c2 * a2 - 1.0)
    hc1, hc2 = h * c1, h * c2
    xx, yy, zz, xy, xz, yz = tx * tx, ty * ty, tz * tz, tx * ty, tx * tz, ty * tz
    return np.array((
        (d11 + c1 * xx, s1 * tz + c1 * xy, -s1 * ty + c1 * xz,
         d12 - hc2 * xx, -hc1 * tz - hc2 * xy, hc1 * ty - hc2 * xz),
        (-s1 * tz + c1 * xy, d11 + c1 * yy, s1 * tx + c1 * yz,
         hc1 * tz - hc2 * xy, d12 - hc2 * yy, -hc1 * tx - hc2 * yz),
        (s1 * ty + c1 * xz, -s1 * tx + c1 * yz, d11 + c1 * zz,
         -hc1 * ty - hc2 * xz, hc1 * tx - hc2 * yz, d12 - hc2 * zz),
        (0.0, 0.0, 0.0, 1.0, 0.0, 0.0),
        (0.0, 0.0, 0.0, 0.0, 1.0, 0.0),
        (0.0, 0.0, 0.0, 0.0, 0.0, 1.0),
    ))


def gyro_process_noise(sigma_v2, sigma_u2, h):
    """Qd (6x6) of Farrenkopf's gyro model over h [s]: angle random walk density sigma_v2 [rad^2/s], bias
    random walk density sigma_u2 [rad^2/s^3] (module doc)."""
    q = np.zeros((6, 6))
    q11 = sigma_v2 * h + sigma_u2 * h ** 3 / 3.0
    q12 = -0.5 * sigma_u2 * h * h
    q22 = sigma_u2 * h
    for i in range(3):
        q[i, i], q[i, i + 3], q[i + 3, i], q[i + 3, i + 3] = q11, q12, q12, q22
    return q


@dataclasses.dataclass(frozen=True, eq=False)
class SteadyState:
    """The filter's steady-state covariance for a constant bias-corrected rate (``steady_state``).

    Attributes:
        omega_body: the rate it holds for [rad/s].
        prior: 6x6 covariance just before a star-tracker update; posterior: just after it.
        attitude_sigma_rad: per body axis, the rms over the gyro samples of one star-tracker period of
            the attitude sigma (the accuracy of an estimate taken at any IMU sample) (3,).
        bias_sigma_rad_s: per body axis, the bias sigma after an update (3,).
    """

    omega_body: np.ndarray
    prior: np.ndarray
    posterior: np.ndarray
    attitude_sigma_rad: np.ndarray
    bias_sigma_rad_s: np.ndarray


def steady_state(config, omega_body=(0.0, 0.0, 0.0)):
    """The steady state of the filter's own covariance for a body turning at the constant rate omega_body
    [rad/s] (an inertially fixed body by default), with rate_hz / star_tracker_rate_hz gyro steps
    between star-tracker samples (rounded to an integer).

    Over one star-tracker period the error model is time invariant (the same Phi and Qd every gyro step),
    so the prior covariance is the solution of the discrete algebraic Riccati equation
    P = A P A' - A P H' (H P H' + R)^-1 H P A' + Q of that period (scipy.linalg.solve_discrete_are),
    the numerical counterpart of Farrenkopf's (1978) analytic steady state; the posterior and the sigma
    at each gyro sample follow from it. The accuracy a consistent filter reaches after it converges.
    """
    steps = max(1, round(config.rate_hz / config.star_tracker_rate_hz))
    h = 1.0 / config.rate_hz
    w = np.asarray(omega_body, dtype=float)
    phi = error_transition(step_rotation_vector(w, w, h), h)
    qd = gyro_process_noise(config.gyro_noise_sigma_rad_s ** 2 / config.rate_hz,
                            config.gyro_bias_walk_rad_s_sqrt_s ** 2, h)
    a, q = np.eye(6), np.zeros((6, 6))
    for _ in range(steps):
        a, q = phi @ a, phi @ q @ phi.T + qd
    hm = np.hstack((np.eye(3), np.zeros((3, 3))))
    r = config.star_tracker_sigma_rad ** 2 * np.eye(3)
    prior = solve_discrete_are(a.T, hm.T, q, r)  # P = A P A' - A P H' (H P H' + R)^-1 H P A' + Q
    prior = 0.5 * (prior + prior.T)
    _, _, posterior = kalman_update_first_three(_ZERO_STATE, prior, np.zeros(3), r)
    variances, p = [], posterior
    for _ in range(steps):
        variances.append(np.diag(p)[:3])
        p = phi @ p @ phi.T + qd
    return SteadyState(w, prior, posterior, np.sqrt(np.mean(variances, axis=0)), np.sqrt(np.diag(posterior)[3:]))


class ChaserAttitudeFilter(FilterBase):
    """Multiplicative EKF of the chaser's attitude and gyro bias from its IMU (module doc); a
    ``filter_interface.EstimationFilter`` whose measurement (``update``) is the star tracker.

    Typical use (the estimator, at each ``/sensors/chaser/imu`` message):

        f = ChaserAttitudeFilter(ChaserAttitudeFilterParams.from_scenario(sc).config())  # flyby_estimation.params
        gyro, star = f.on_imu(t, omega_body_meas, q_hill_from_body_meas)   # q None when absent
        for sensor, result in (('gyro', gyro), ('star_tracker', star)):
            if result is not None and not result.accepted:
                warn(sensor, result.kind, result.reason)
        if f.ready:
            e = f.estimate()          # ChaserAttitudeEstimate at f.t
    """

    def __init__(self, config):
        super().__init__(config.gate_probability, config.max_consecutive_outliers, config.star_tracker_sigma_rad,
                         ATTITUDE_FRAMES, rotation=True)
        self.config = config
        self._n = config.mean_motion_rad_s
        self._r = config.star_tracker_sigma_rad ** 2 * np.eye(3)
        self._sigma_v2 = config.gyro_noise_sigma_rad_s ** 2 / config.rate_hz  # angle random walk [rad^2/s]
        self._sigma_u2 = config.gyro_bias_walk_rad_s_sqrt_s ** 2  # bias random walk [rad^2/s^3]
        self._hold = config.gyro_interpolation == 'hold'
        self._q = None  # reference q_eci_from_body
        self._p = None  # 6x6 covariance of [dtheta_body, dbias_body]
        self._bias = np.zeros(3)  # estimated gyro bias [rad/s], body axes
        self._gyro = None  # (t, omega_meas as 3 floats) of the latest accepted gyro sample
        self._gyro_gap_s = None  # a gap in the gyro beyond staleness [s] since the last star-tracker sample, or None
        self._qd_cache = {}  # Qd per step length (the IMU's stamps give a handful of distinct steps)
        self.gyro_counts = new_counts()

    # -- state ------------------------------------------------------------------------------------
    @property
    def ready(self):
        """True once a star-tracker sample has set the attitude and a gyro sample is held (estimate())."""
        return self.initialized and self._gyro is not None

    @property
    def covariance(self):
        """6x6 covariance of [dtheta_body, dbias_body] at the filter time (a copy)."""
        self._require_initialized('covariance')
        return self._p.copy()

    def estimate(self):
        """ChaserAttitudeEstimate at the filter time t (the latest gyro or star-tracker stamp)."""
        self._require_ready('estimate')
        return self._estimate(self._t, self._q, self._p)

    def state(self):
        """The estimate at the filter time (``estimate``), the EstimationFilter verb."""
        return self.estimate()

    def _estimate(self, t, q, p):
        return ChaserAttitudeEstimate(t=float(t), q_eci_from_body=q.copy(),
                                      q_hill_from_body=q_hill_from_body(t, self._n, q),
                                      omega_body=np.array(self._gyro[1]) - self._bias, bias_rad_s=self._bias.copy(),
                                      covariance=p.copy(), gyro_noise_sigma_rad_s=self.config.gyro_noise_sigma_rad_s)

    # -- time update --------------------------------------------------------------------------------
    def _step(self, q, p, omega_a, omega_b, h):
        """(q, P) after h [s] at the bias-corrected rate going linearly from omega_a to omega_b (module doc)."""
        bx, by, bz = self._bias.tolist()
        wa = (omega_a[0] - bx, omega_a[1] - by, omega_a[2] - bz)
        wb = (omega_b[0] - bx, omega_b[1] - by, omega_b[2] - bz)
        theta = step_rotation_vector(wa, wb, h)
        q = quat_normalize(quat_multiply(q, quat_from_rotation_vector(theta)))  # seed 000 eq 4 over h
        phi = error_transition(theta, h)
        qd = self._qd_cache.get(h)
        if qd is None:
            qd = self._qd_cache[h] = gyro_process_noise(self._sigma_v2, self._sigma_u2, h)
        p = phi @ p @ phi.T + qd  # P = Phi P Phi' + Qd
        return q, 0.5 * (p + p.T)

    def _step_rates(self, t, w):
        """Measured rates at the filter time and at t for the step to the new gyro sample w at t > the filter
        time: the latest sample ('hold'); w alone when it is the first; else ('linear') the linear
        interpolant of the latest sample and w. If the filter was carried past the latest sample by
        holding it (propagate_to, a star-tracker stamp between gyro samples), the start rate is raised
        so that this step also turns through what the hold left out of the interpolant,
        (w - w_g) (t_f - t_g)^2 / (2 (t - t_g)): the attitude at t is then the unsplit step's to O(h^2)."""
        if self._gyro is None:
            return w, w
        t_g, w_g = self._gyro
        if self._hold:
            return w_g, w_g
        f = (self._t - t_g) / (t - t_g)  # t > filter time >= t_g
        # interpolant at the filter time, plus 2 / h times the missed rotation f^2 (t - t_g) / 2 (w - w_g)
        g = f + f * f * (t - t_g) / (t - self._t)
        return tuple(a + g * (b - a) for a, b in zip(w_g, w, strict=True)), w

    def _latest_time(self):
        """The filter time, or before initialization the latest gyro stamp (None before any)."""
        if self.initialized:
            return self._t
        return None if self._gyro is None else self._gyro[0]

    def propagate_to(self, t):
        """Time update to t [s] >= the filter time without a new gyro sample: the latest gyro sample is
        held (an extrapolation; the next gyro sample continues from there)."""
        self._require_ready('propagate_to')
        if not (math.isfinite(t) and t >= self._t):
            raise ValueError(f'propagate_to: t = {t} s is before the filter time {self._t} s (or not finite)')
        if t > self._t:
            w = self._gyro[1]
            self._q, self._p = self._step(self._q, self._p, w, w, t - self._t)
            self._t = float(t)

    def predict(self, t):
        """ChaserAttitudeEstimate at t [s] >= the filter time, the latest gyro sample held; the filter is
        unchanged."""
        self._require_ready('predict')
        if not (math.isfinite(t) and t >= self._t):
            raise ValueError(f'predict: t = {t} s is before the filter time {self._t} s (or not finite)')
        q, p = self._q, self._p
        if t > self._t:
            w = self._gyro[1]
            q, p = self._step(q, p, w, w, t - self._t)
        return self._estimate(t, q, p)

    def on_gyro(self, t, omega_body_meas):
        """Propagate to the gyro sample omega_body_meas [rad/s, body axes] stamped t [s] (module doc).

        Returns an UpdateResult counted in ``gyro_counts``: 'accepted' (the filter moved to t; before the
        first star-tracker sample the sample is only kept), 'non_finite' (not a finite stamp and 3
        finite numbers), 'stale' (stamped before the filter time or the latest gyro sample; equal is
        accepted and replaces it). A rejected sample leaves the filter unchanged.
        """
        counts = self.gyro_counts
        w, rejected = self._finite_measurement(t, omega_body_meas, 3, 'gyro sample', counts)
        if rejected is not None:
            return rejected
        stale = self._stale_measurement(t, self._latest_time(), 'gyro sample', counts)
        if stale is not None:
            return stale
        t = float(t)
        w = tuple(w.tolist())
        if self.initialized and t > self._t:
            if self._gyro is not None and t - self._gyro[0] > STALE_PERIODS / self.config.rate_hz:
                self._gyro_gap_s = t - self._gyro[0]
            w_a, w_b = self._step_rates(t, w)
            self._q, self._p = self._step(self._q, self._p, w_a, w_b, t - self._t)
            self._t = t
        self._gyro = (t, w)
        return self._outcome('accepted', t, counts=counts)

    # -- measurement update ---------------------------------------------------------------------------
    def on_star_tracker(self, t, q_hill_from_body_meas):
        """Fuse the star-tracker attitude q_hill_from_body (x, y, z, w) stamped t [s] (module doc).

        Returns an UpdateResult counted in ``counts``: 'initialized' (the first one sets the attitude),
        'accepted', 'reset', or rejected as 'non_finite', 'non_unit' (norm off by more than
        norm_tolerance), 'stale' (before the filter time, or before the latest gyro sample while not
        initialized) or 'outlier' (outside the chi2 gate; the filter has then been propagated to t).
        A stamp past the latest gyro sample is reached by holding that sample (``propagate_to``).
        """
        z, rejected = self._unit_quaternion_measurement(t, q_hill_from_body_meas, self.config.norm_tolerance,
                                                        'star-tracker attitude')
        if rejected is not None:
            return rejected
        stale = self._stale_measurement(t, self._latest_time(), 'star-tracker attitude')
        if stale is not None:
            return stale
        q_eci_meas = q_eci_from_body(t, self._n, z)
        if not self.initialized:
            self._initialize(t, q_eci_meas, self.config.gyro_bias_sigma_rad_s ** 2 * np.eye(3))
            return self._outcome('initialized', t)
        if t > self._t:
            if self._gyro is None:
                raise RuntimeError(f'star-tracker attitude at t = {t} s: no gyro sample to propagate the '
                                   f'attitude from {self._t} s')
            self.propagate_to(t)
        if self._gyro_gap_s is not None:
            gap_s, self._gyro_gap_s = self._gyro_gap_s, None
            self._initialize(t, q_eci_meas, self._p[3:, 3:])
            return self._outcome('initialized', t, reason=f'star-tracker attitude at t = {t} s after a gyro gap of '
                                                           f'{gap_s:.3g} s: attitude set from it, bias kept')
        nu = attitude_innovation(self._q, q_eci_meas)  # the measured body-frame attitude error
        # d2 = nu' S^-1 nu, S = H P H' + R; K = P H' S^-1; dx = K nu (x = 0 after every reset);
        # P = (I - K H) P (I - K H)' + K R K' (Joseph form)
        d2, dx, p = kalman_update_first_three(_ZERO_STATE, self._p, nu, self._r)
        verdict = self._gate_verdict(d2, t, lambda: attitude_errors(self._q, q_eci_meas))
        if verdict != 'pass':
            innovation_deg = math.degrees(float(np.linalg.norm(nu)))
            if verdict == 'reset':
                p_bias = self._p[3:, 3:]
                floor = self.config.gyro_bias_sigma_rad_s ** 2
                self._initialize(t, q_eci_meas, p_bias + np.diag(np.maximum(floor - np.diag(p_bias), 0.0)))
                return self._outcome('reset', t, d2, f'{self.config.max_consecutive_outliers} consecutive star-tracker '
                                                     f'outliers {self._rejected.agreement}, the last '
                                                     f'{innovation_deg:.3g} deg at t = {t} s (d2 = {d2:.4g} > gate '
                                                     f'{self._gate:.4g}): attitude re-initialized from it, bias kept',
                                     nu)
            return self._outcome('outlier', t, d2, f'star-tracker innovation {innovation_deg:.3g} deg at t = {t} s: '
                                                   f'd2 = {d2:.4g} > gate {self._gate:.4g}', nu)
        # Reset: the error folded into the reference (Markley), the bias correction added
        self._q, self._p = fold_attitude_error(self._q, dx[:3, 0], p)
        self._bias = self._bias + dx[3:, 0]
        return self._outcome('accepted', t, d2, '', nu)

    def update(self, t, q_hill_from_body_meas):
        """The EstimationFilter verb: ``on_star_tracker``."""
        return self.on_star_tracker(t, q_hill_from_body_meas)

    def on_imu(self, t, omega_body_meas, q_hill_from_body_meas=None):
        """One IMU sample stamped t [s]: the gyro first (``on_gyro``), then the star tracker at the same stamp
        when present (``on_star_tracker``). Returns (gyro UpdateResult, star-tracker UpdateResult or None)."""
        gyro = self.on_gyro(t, omega_body_meas)
        star = None if q_hill_from_body_meas is None else self.on_star_tracker(t, q_hill_from_body_meas)
        return gyro, star

    def _initialize(self, t, q_eci_meas, p_bias):
        self._t = float(t)
        self._q = q_eci_meas
        p = np.zeros((6, 6))
        p[:3, :3] = self.config.attitude_sigma0_rad ** 2 * np.eye(3)
        p[3:, 3:] = p_bias
        self._p = 0.5 * (p + p.T)
        self._rejected.clear()

    def _require_initialized(self, what):
        if not self.initialized:
            raise RuntimeError(f'{what}: the chaser attitude filter has no star-tracker sample yet')

    def _require_ready(self, what):
        self._require_initialized(what)
        if self._gyro is None:
            raise RuntimeError(f'{what}: the chaser attitude filter has no gyro sample yet')
