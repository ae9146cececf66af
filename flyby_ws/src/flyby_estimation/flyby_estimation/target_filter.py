"""Target attitude-motion filter: a multiplicative extended Kalman filter with filterpy's arithmetic (no ROS).

Estimates the attitude and inertial angular velocity of the tumbling target from vision attitude
measurements q_hill_from_body at 10 Hz (seed 001 section 2), with the target's inertia known
(seed 001 section 1), so that its future motion can be predicted with seed 000 eq 4 and 6-9.

Conventions are those of ``target_motion``: quaternions (x, y, z, w), scalar last; the reference
attitude is q_eci_from_body, integrated in inertial space (seed 000 eq 4); error state
x = [dtheta_body, domega_body] with q_true = q_ref * exp(dtheta_body) (a body-frame rotation vector)
and omega_true = omega_ref + domega_body.

The filter (the EKF of seed 004 section 2.2 in the multiplicative form of its ref. 3, Lefferts,
Markley and Shuster 1982):

- time update: the reference (q, omega) follows the torque-free Euler equation with the known inertia
  (seed 000 eq 4, seed 001 eq 3), RK4 substeps; P <- Phi P Phi' + Qd with Phi and Qd of each substep
  in closed form (attitude_error_dynamics.ErrorStateDynamics.propagate), filterpy's KalmanFilter.predict arithmetic
  without its bookkeeping.
- measurement: z = q_hill_from_body at stamp t, taken to inertial with quat_eci_from_hill(t, n);
  the innovation is the body-frame rotation vector nu = log(q_ref^-1 * q_meas), so H = [I 0] and
  R = sigma^2 I per body axis (the plant's sensor model: a Gaussian body-frame rotation error); the
  update is filterpy's arithmetic for that H (filter_interface.kalman_update_first_three).
- gating: the normalized innovation squared d2 = nu' S^-1 nu against chi2(3) at gate_probability;
  rejected measurements are not fused. A run of ``max_consecutive_outliers`` outliers in a row that agree
  with each other (filter_interface's restart rule: a smooth error in the body or the inertial frame)
  restarts the filter from its last measurement (a wrong first measurement or a real jump would otherwise
  lock it out); random outliers, however many in a row, do not.
- reset: the estimated error is folded into the reference (q <- q * exp(dtheta), omega += domega)
  and zeroed, so q stays unit and the attitude covariance stays 3x3.

The verbs and outcomes are those of ``filter_interface``: ``update`` returns an ``UpdateResult``
(kinds 'initialized', 'accepted', 'reset', 'non_finite', 'non_unit', 'stale', 'outlier', counted in
``counts``), ``propagate_to`` moves the filter time, ``predict`` leaves the filter unchanged.

Initialization (and restart) from the first accepted measurement: attitude = the measurement (sigma per axis =
the sensor's), rate = 0 with sigma rate_sigma0 per axis. A finite difference of the first two
measurements would not help: at 10 Hz with 1 deg noise it has a sigma of sqrt(2) deg / 0.1 s =
14 deg/s per axis, no better than the prior, whereas the Kalman update weighs every following
measurement optimally.
"""

import collections
import dataclasses
import math

import numpy as np

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_estimation.batch import check_filter, fit_attitude_motion
from flyby_estimation.filter_interface import (
    ATTITUDE_FRAMES,
    FilterBase,
    UpdateResult,
    attitude_errors,
    check_run_length,
    kalman_update_first_three,
)
from flyby_estimation.motion_category import classify_motion
from flyby_estimation.quaternion_floats import (
    q_eci_from_hill_floats,
    quat_exp_floats,
    quat_normalize_floats,
    quat_product_floats,
    rotation_vector_floats,
)
from flyby_estimation.target_motion import MotionPrediction, make_state, point_prediction
from flyby_msgs_py import params
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.orbital import q_hill_from_body
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_multiply,
    rotation_angle_many,
)

_ZERO_STATE = np.zeros((6, 1))  # the error state between updates (reset after each)
_I6 = np.eye(6)


@dataclasses.dataclass(frozen=True)
class TargetFilterConfig:
    """Parameters of TargetAttitudeFilter (validated; ValueError names the field).

    The fields up to check_window_max_samples are the scenario's (``params.TargetFilterParams.config``: their
    defaults are the scenario schema's); the rest are the filter's own, with defaults.

    Attributes:
        inertia: target inertia 3x3 [kg m^2], body axes (known, seed 001 section 1).
        mean_motion_rad_s: orbital mean motion n [rad/s] of the hill frame.
        attitude_sigma_rad: vision attitude noise, 1 sigma per body axis [rad].
        rate_sigma0_rad_s: prior 1-sigma per axis of the unknown initial rate (mean 0) [rad/s]
            (estimation.initial_rate_sigma_deg_s: 20 deg/s covers category III (<= 18 deg/s) and the seed 001
            tumbler (21 deg/s)).
        torque_psd: torque-noise spectral density per body axis [N^2 m^2 s] (estimation.torque_psd_n2m2s: 1e-10
            over a 600 s prediction adds about 1e-7 rad/s of rate uncertainty to a 1000 kg m^2 body, negligible
            against the estimation error, while keeping P from collapsing on long runs). The plant is torque free;
            raise it if the truth has unmodelled torques (gravity gradient).
        gate_probability: chi2(3) probability of the innovation gate (0.9999: d2 < 21.1).
        check_window_max_samples: fused measurements kept for batch_check (estimation.batch_check_max_samples);
            past that the window is dropped and batch_check refuses.
        norm_tolerance: measurements with |norm - 1| above this are rejected as 'non_unit'.
        max_consecutive_outliers: N, the run of consecutive outliers whose agreement restarts the filter from
            its last measurement (filter_interface's restart rule: a wrong initial measurement or a real jump
            would otherwise lock it out, random outliers never restart it); N >= MIN_RUN_SAMPLES.
        max_step_angle_rad: substep limit, as a rotation angle (attitude_error_dynamics.ErrorStateDynamics.propagate).
        excursion_window_s: window of estimated hill attitudes kept for classify_motion.
    """

    inertia: tuple
    mean_motion_rad_s: float
    attitude_sigma_rad: float
    rate_sigma0_rad_s: float
    torque_psd: float
    gate_probability: float
    check_window_max_samples: int
    norm_tolerance: float = 1e-3
    max_consecutive_outliers: int = 20
    max_step_angle_rad: float = 0.02
    excursion_window_s: float = 600.0

    def __post_init__(self):
        object.__setattr__(self, 'inertia', tuple(map(tuple, np.asarray(self.inertia, dtype=float).tolist())))
        for name in ('mean_motion_rad_s', 'attitude_sigma_rad', 'rate_sigma0_rad_s', 'norm_tolerance',
                     'max_step_angle_rad', 'excursion_window_s'):
            require_positive(name, getattr(self, name))
        require_positive('torque_psd', self.torque_psd, allow_zero=True)
        if not 0.0 < self.gate_probability < 1.0:
            raise ValueError(f'gate_probability must be in (0, 1), got {self.gate_probability}')
        check_run_length(self.max_consecutive_outliers)
        if not (isinstance(self.check_window_max_samples, int) and self.check_window_max_samples >= 1):
            raise ValueError('check_window_max_samples must be an integer >= 1, got '
                             f'{self.check_window_max_samples!r}')


@params.record
class ConvergenceThresholds:
    """3-sigma bounds below which the estimate counts as converged (worst direction of each 3x3 block), the
    scenario's ``estimation`` keys (flyby_msgs_py.params).

    The schema's attitude 1 deg and rate 0.05 deg/s: a 2 m grasp point then sits within 3.5 cm now and
    drifts by at most 0.05 deg/s * 2 m = 1.7 mm/s (3 sigma).
    """

    attitude_3sigma_rad: float = params.key('estimation.convergence_attitude_3sigma_deg', math.radians)
    rate_3sigma_rad_s: float = params.key('estimation.convergence_rate_3sigma_deg_s', math.radians)

    def met_by(self, attitude_3sigma_rad, rate_3sigma_rad_s):
        """True when both 3-sigma bounds (TargetAttitudeFilter.three_sigma) are below the thresholds."""
        return attitude_3sigma_rad < self.attitude_3sigma_rad and rate_3sigma_rad_s < self.rate_3sigma_rad_s


class TargetAttitudeFilter(FilterBase):
    """Multiplicative EKF of the target attitude and inertial angular velocity (module doc); a
    ``filter_interface.EstimationFilter``.

    Typical use (the node):

        f = TargetAttitudeFilter(TargetFilterParams.from_scenario(sc).config())  # flyby_estimation.params
        result = f.update(t, q_hill_from_body)
        if not result.accepted:
            warn(result.kind, result.reason)  # counted in f.counts as well
        s = f.state()                     # PredictedState at f.t
        g = f.body_point_in_hill(sc.target.grasp_point_body_m, t_grasp)
    """

    def __init__(self, config):
        super().__init__(config.gate_probability, config.max_consecutive_outliers, config.attitude_sigma_rad,
                         ATTITUDE_FRAMES, rotation=True)
        self.config = config
        self.dynamics = ErrorStateDynamics(config.inertia, config.torque_psd)
        self._n = config.mean_motion_rad_s
        self._r = config.attitude_sigma_rad ** 2 * np.eye(3)
        self._p = None  # 6x6 covariance of the error state, which is 0 between updates (reset after each)
        self._q = None  # reference q_eci_from_body
        self._omega = None  # reference omega_body [rad/s]
        self._history = collections.deque()  # (t, q_hill_from_body) at ~1 Hz for classify_motion
        self._window = []  # (t, q_hill_from_body) fused since the last initialization, for batch_check

    # -- state ------------------------------------------------------------------------------------
    @property
    def covariance(self):
        """6x6 error-state covariance [dtheta_body, domega_body] at the filter time (a copy)."""
        self._require_initialized()
        return self._p.copy()

    def state(self):
        """target_motion.PredictedState at the filter time t (last measurement or propagate_to)."""
        self._require_initialized()
        # P is kept exactly symmetric: 0.5 (P + P') would be P again, to the bit
        return make_state(self._t, self._n, self._q, self._omega, self._p.copy(), symmetric=True)

    # -- time and measurement updates ---------------------------------------------------------------
    def propagate_to(self, t):
        """Time update to t [s] >= the filter time, in place, without a measurement (seed 000 eq 4)."""
        self._require_initialized()
        if not (math.isfinite(t) and t >= self._t):
            raise ValueError(f'propagate_to: t = {t} s is before the filter time {self._t} s (or not finite)')
        if t == self._t:
            return
        q, omega, phi, qd = self.dynamics.propagate(self._q, self._omega, t - self._t, self.config.max_step_angle_rad)
        # P = Phi P Phi' + Qd: filterpy's predict arithmetic without its bookkeeping (x = Phi x stays 0:
        # x = 0 after every reset)
        p = phi.dot(self._p).dot(phi.T) + qd  # ndarray.dot: @'s BLAS product at half its cost per call
        self._p = 0.5 * (p + p.T)  # exactly symmetric despite rounding
        self._q, self._omega, self._t = q, omega, float(t)

    def update(self, t, q_hill_from_body_meas):
        """Fuse the vision attitude q_hill_from_body (x, y, z, w) measured at sim time t [s].

        Returns an UpdateResult (filter_interface), counted in ``counts``: rejected as 'non_finite' (not a
        finite stamp and 4 finite numbers), 'non_unit' (norm off by more than norm_tolerance), 'stale'
        (stamp before the filter time) or 'outlier' (innovation outside the chi2 gate, the filter then
        propagated to t); the filter keeps running.
        """
        z = np.asarray(q_hill_from_body_meas, dtype=float)
        if z.shape != (4,) or not all(map(math.isfinite, z.tolist())) or not math.isfinite(t):
            return self._outcome('non_finite', t, reason=f'measurement at t = {t} s is not a finite quaternion and '
                                                         f'time: {q_hill_from_body_meas!r}')
        norm = math.sqrt(z.dot(z))  # np.linalg.norm's arithmetic for a vector
        if abs(norm - 1.0) > self.config.norm_tolerance:
            return self._outcome('non_unit', t, reason=f'measurement at t = {t} s has norm {norm:.6g}, not within '
                                                       f'{self.config.norm_tolerance} of 1')
        z = z / norm
        # orbital.q_eci_from_body(t, n, z) and the quaternion algebra below on floats (quaternion_floats:
        # rotation's expressions, the same bits, without an array per product)
        q_eci_meas = quat_product_floats(q_eci_from_hill_floats(t, self._n), z.tolist())
        if not self.initialized:
            self._initialize(t, np.array(q_eci_meas), z)
            return self._outcome('initialized', t)
        if t < self._t:
            return self._outcome('stale', t, reason=f'measurement stamped t = {t} s is before the filter time '
                                                    f'{self._t} s')
        self.propagate_to(t)
        # nu = log(q_ref^-1 * q_meas): the measured body-frame attitude error
        x, y, z_, w = self._q.tolist()
        nu = np.array(rotation_vector_floats(quat_product_floats((-x, -y, -z_, w), q_eci_meas)))
        # d2 = nu' S^-1 nu, S = H P H' + R; K = P H' S^-1; dx = K nu (x = 0 after every reset);
        # P = (I-KH) P (I-KH)' + K R K' (Joseph form). The Joseph form keeps P symmetric positive
        # definite under rounding, which matters here because the rate variance falls by ~10 orders
        # of magnitude from the 20 deg/s prior.
        d2, dx, p = kalman_update_first_three(_ZERO_STATE, self._p, nu, self._r)
        verdict = self._gate_verdict(d2, t, lambda: attitude_errors(self._q, q_eci_meas))
        if verdict != 'pass':
            innovation_deg = math.degrees(float(np.linalg.norm(nu)))
            if verdict == 'reset':
                self._initialize(t, np.array(q_eci_meas), z)
                return self._outcome('reset', t, d2, f'{self.config.max_consecutive_outliers} consecutive outliers '
                                                     f'{self._rejected.agreement}, the last {innovation_deg:.3g} deg '
                                                     f'at t = {t} s (d2 = {d2:.4g} > gate {self._gate:.4g}): '
                                                     f're-initialized from it', nu)
            return self._outcome('outlier', t, d2, f'innovation {innovation_deg:.3g} deg at t = {t} s: d2 = {d2:.4g} '
                                                   f'> gate {self._gate:.4g}', nu)
        # Reset: fold the error into the reference and zero it. The attitude block is turned by the
        # reset Jacobian G = I - 1/2 [dtheta x] (Markley), dtheta' = G (dtheta - dtheta_hat).
        dtheta = a, b, c = dx[:3, 0].tolist()
        self._q = np.array(quat_normalize_floats(quat_product_floats((x, y, z_, w), quat_exp_floats(dtheta))))
        self._omega = self._omega + dx[3:, 0]
        g = _I6.copy()
        # G = I - 0.5 [dtheta x], written out: I[:3, :3] - 0.5 * skew(dtheta) element by element
        g[:3, :3] = ((1.0 - 0.5 * 0.0, 0.0 - 0.5 * -c, 0.0 - 0.5 * b),
                     (0.0 - 0.5 * c, 1.0 - 0.5 * 0.0, 0.0 - 0.5 * -a),
                     (0.0 - 0.5 * -b, 0.0 - 0.5 * a, 1.0 - 0.5 * 0.0))
        p = g.dot(p).dot(g.T)  # P = G P G'
        self._p = 0.5 * (p + p.T)
        self._accept(t, z)
        return self._outcome('accepted', t, d2, '', nu)

    def _outcome(self, kind, t, nis=math.nan, reason='', innovation=None):
        self.counts[kind] += 1
        return UpdateResult(kind, float(t), nis, reason, innovation)

    def _initialize(self, t, q_eci_meas, z):
        sigma_w = self.config.rate_sigma0_rad_s
        self._t = float(t)
        self._q = q_eci_meas
        self._omega = np.zeros(3)
        self._p = np.diag([self.config.attitude_sigma_rad ** 2] * 3 + [sigma_w ** 2] * 3)
        self._rejected.clear()
        self._history.clear()
        self._window = []
        self._accept(t, z)

    def _accept(self, t, z):
        if self._window is not None:
            self._window.append((float(t), z))
            if len(self._window) > self.config.check_window_max_samples:
                self._window = None
        history = self._history
        if history and self._t - history[-1][0] < 1.0:
            return
        history.append((self._t, q_hill_from_body(self._t, self._n, self._q)))
        while self._t - history[0][0] > self.config.excursion_window_s:
            history.popleft()

    def batch_check(self):
        """batch.FilterCheck of the estimate against the batch maximum-likelihood fit of every
        measurement fused since the last (re)initialization: an efficient filter equals the fit and
        its Cramer-Rao bound (docs/estimation.md). Costs one nonlinear fit: 0.05 s for 200 samples,
        0.17 s for 700 and 0.4 s for 2000 samples of a 15 deg/s tumbler. The filter is unchanged.

        Raises RuntimeError if the filter was propagated past its last measurement or kept more
        than check_window_max_samples, ValueError for fewer than 3 measurements.
        """
        self._require_initialized()
        if self._window is None:
            raise RuntimeError(f'more than {self.config.check_window_max_samples} measurements since the '
                               f'last initialization: the check window was dropped')
        if self._window[-1][0] != self._t:
            raise RuntimeError(f'the filter time {self._t} s is past its last measurement {self._window[-1][0]} s')
        times, measurements = zip(*self._window, strict=True)
        s = self.state()
        fit = fit_attitude_motion(times, measurements, self._n, self.config.inertia,
                                  self.config.attitude_sigma_rad, s.q_eci_from_body, s.omega_body)
        return check_filter(s.q_eci_from_body, s.omega_body, s.covariance, fit)

    def _require_initialized(self):
        if not self.initialized:
            raise RuntimeError('the target filter has no accepted measurement yet')

    # -- convergence and category -------------------------------------------------------------------
    def three_sigma(self):
        """(attitude, rate) 3-sigma bounds [rad, rad/s] in the worst direction of each 3x3 block."""
        self._require_initialized()
        p = self._p
        largest = np.linalg.eigvalsh(np.array((p[:3, :3], p[3:, 3:])))[:, -1]  # both blocks in one call
        return 3.0 * math.sqrt(max(largest[0], 0.0)), 3.0 * math.sqrt(max(largest[1], 0.0))

    def convergence(self, thresholds):
        """True when both 3-sigma bounds (three_sigma) are below the thresholds.

        The largest eigenvalue of a 3x3 covariance block lies between a third of its trace and its trace,
        so the verdict mostly follows from the two traces; the eigenvalues are computed only in between.
        The margins of 1e-9 keep the verdict that of three_sigma despite rounding (the estimator's
        convergence events at the same stamps, test_convergence_from_traces_is_that_of_three_sigma).
        """
        if not self.initialized:
            return False
        d = self._p.diagonal().tolist()
        limits = ((d[0] + d[1] + d[2], thresholds.attitude_3sigma_rad ** 2 / 9.0),
                  (d[3] + d[4] + d[5], thresholds.rate_3sigma_rad_s ** 2 / 9.0))  # (trace, sigma^2 limit)
        if all(trace < limit * (1.0 - 1e-9) for trace, limit in limits):
            return True  # largest eigenvalue <= trace
        if any(trace > 3.0 * limit * (1.0 + 1e-9) for trace, limit in limits):
            return False  # largest eigenvalue >= trace / 3
        return thresholds.met_by(*self.three_sigma())

    def attitude_excursion_rad(self):
        """Largest rotation between the current estimated hill attitude and any in the window [rad]."""
        self._require_initialized()
        q_now_inv = quat_conjugate(q_hill_from_body(self._t, self._n, self._q))
        q_hill_from_body_then = np.array([q for _, q in self._history])
        return float(rotation_angle_many(quat_multiply(q_now_inv, q_hill_from_body_then.T).T).max())

    def classify_motion(self, thresholds):
        """motion_category.MotionCategory (seed 000 section 2.1) from the estimated rate and attitude excursion.

        Meaningful once converged; the excursion covers the time since initialization, up to
        excursion_window_s.
        """
        s = self.state()
        return classify_motion(s.omega_hill, self._n, thresholds, self.attitude_excursion_rad())

    # -- prediction (seed 000 eq 4, 6-9) ------------------------------------------------------------
    def prediction(self, t_end, with_covariance=True):
        """target_motion.MotionPrediction from the filter time to t_end [s]: ask it at many times.

        with_covariance=False gives states without covariance (the same motion; the covariance costs
        nothing until first asked for).
        """
        self._require_initialized()
        return MotionPrediction(self.dynamics, self._n, self._t, self._q, self._omega, self._p, t_end,
                                with_covariance=with_covariance)

    def predict(self, t_future):
        """PredictedState at t_future >= filter time: attitude, omega_body, omega_hill (eq 6), covariance.

        Does not change the filter.
        """
        return self.prediction(t_future).state(t_future)

    def body_point_in_hill(self, x_body, t_future):
        """BodyPointPrediction of the body point x_body [m] at t_future (seed 000 eq 8-9): position
        and velocity (relative to the rotating hill frame) in hill with their 6x6 covariance."""
        return point_prediction(self.predict(t_future), x_body, self._n)
