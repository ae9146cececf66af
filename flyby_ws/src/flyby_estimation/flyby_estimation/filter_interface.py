"""What the estimation filters have in common: the outcome of a measurement, the verbs and the restart rule (no ROS).

``relative_nav.RelativeNavFilter`` (chaser position), ``target_filter.TargetAttitudeFilter`` (target attitude) and
``chaser_attitude_filter.ChaserAttitudeFilter`` (chaser attitude, star tracker) follow ``EstimationFilter``:

- ``update(t, z)`` processes one measurement and returns an ``UpdateResult``; it does not raise for a
  bad measurement. Every outcome is counted by kind in ``counts``.
- ``propagate_to(t)`` is the time update: the filter moves to t (later measurements stamped before t
  are then 'stale').
- ``predict(t)`` returns the state predicted to t and leaves the filter unchanged.
- ``state()`` returns the state at the filter time ``t``.

Outcome kinds: 'initialized' (the first measurement set the state), 'accepted' (fused), 'reset'
(lost: the restart rule below restarts the filter from that measurement), or a rejection, which leaves the
state unchanged: 'non_finite' (not a finite stamp and the right number of finite values), 'non_unit' (a
quaternion far from unit norm), 'stale' (stamped before the filter time), 'outlier' (normalized innovation
squared above the chi-square gate; the filter has then been propagated to the stamp).

The restart rule (``RejectedRun``): a filter restarts only when the samples its gate rejects agree with each
other, as those of a filter truly lost do (the target mis-tracked, a real jump of what is measured, a burn the
filter did not know of), and random outliers, each off in its own direction, never do: a burst of outliers is no
reason to restart a converged filter (docs/estimation.md: the rule's runs).

- The run: the consecutive gate rejections since the last sample inside the gate (or the last
  (re)initialization); its last N = ``max_consecutive_outliers`` (default 20: 2 s at 10 Hz, 10 s for a 2 Hz star
  tracker; N >= MIN_RUN_SAMPLES) are kept, each as its error from the filter's prediction at its stamp, in each of
  the filter's frames.
- Agreement: with N kept, the run agrees when, in one frame, the errors fit a quadratic in time per axis (least
  squares: an offset, a drift and its change) with residuals whose chi-square in units of the measurement's
  sigma is at most the chi2(3 (N - 3)) quantile at the gate's probability (N = 20 and 0.9999: 97.3 for 51
  degrees of freedom). The errors of a lost filter are a smooth function of time (its prediction is off by an
  offset, a rate or velocity error and an unknown acceleration), so their residual is the measurement noise
  alone, chi2(3 (N - 3)): a lost filter's run agrees with the gate's probability at each test. Each rejected
  sample lies beyond the gate, |error|^2 / sigma^2 > 21.1 at 0.9999, and the fit takes 9 of its 3 N
  components: N random outliers leave about (N - 3) / N of their sum, 359 or more for N = 20, 20-sigma ones
  about 6800.
- Restart: the sample that completes an agreeing run restarts the filter from itself, as each filter's
  restart does (its module doc); a run that does not agree keeps its last N, each new rejection testing again.
  So a lost filter restarts at its N-th consecutive rejection (N sensor periods), or, failing the test by chance
  (1 - gate probability per test), a sample or so later; inside a run, a change of the filter's prediction
  that is not smooth (a known burn's start, a measured thrust error, the navigation filter) may delay it to
  the N-th rejection after that change.
- Frames: the position's error z - H x in hill axes. An attitude's error is a rotation, taken in two frames, the
  run agreeing in either: the body frame, q_ref^-1 q_meas (the innovation; constant when the sensor sees the
  body turned by a fixed body rotation, a mis-track), and the inertial frame, q_meas q_ref^-1 (constant when the
  attitude jumped with its body rates kept: torque-free motion in body axes does not depend on the attitude,
  and a gyro-propagated reference off by a fixed rotation). An offset constant in one frame turns in the other
  at the body rate, which a quadratic does not follow for long runs at the star tracker's precision. The
  rotations are fitted as log(E_m^-1 E_k), each error relative to the middle sample's, so an error near a half
  turn does not wrap.

``mass_properties`` keeps a rule of its own (a measurement taken anyway after N rejections, its module doc).

Helpers the filters share: ``kalman_update_first_three`` (the gated Joseph-form update for H = [I 0]);
``FilterBase`` (filter time, gate, rejected run, outcome counts, and the checks of a measurement's stamp and
values that name the rejection); for the multiplicative attitude filters, whose error state starts
with the body-frame rotation vector dtheta (q_true = q_ref * exp(dtheta), quaternions (x, y, z, w)),
``attitude_innovation``, ``attitude_errors`` (the run's two frames) and ``fold_attitude_error`` (the reset of the
estimated error into the reference, Markley's reset Jacobian).
"""

import collections
import dataclasses
import math
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.linalg._umath_linalg import inv as _inverse
from scipy.stats import chi2

from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_rotation_vector,
    quat_multiply,
    quat_normalize,
    rotation_vector_from_quat,
    skew,
)

REJECTION_KINDS = ('non_finite', 'non_unit', 'stale', 'outlier')
STATE_CHANGING_KINDS = ('initialized', 'accepted', 'reset')
UPDATE_KINDS = STATE_CHANGING_KINDS + REJECTION_KINDS
_IDENTITY = {}  # n -> the n x n identity and its first three columns (_identity)
MIN_RUN_SAMPLES = 10  # fewer and random outliers agree by chance (5-sigma ones: 42 % of tests at 4, 0.2 % at 8)


def check_run_length(length):
    """``max_consecutive_outliers`` as an int, or ValueError naming it: an integer >= MIN_RUN_SAMPLES (the rejected
    run's agreement, module doc)."""
    if isinstance(length, bool) or not isinstance(length, (int, np.integer)) or length < MIN_RUN_SAMPLES:
        raise ValueError(f'max_consecutive_outliers must be an integer >= {MIN_RUN_SAMPLES} (the agreement of the '
                         f'rejected run needs a quadratic fit with a residual), got {length!r}')
    return int(length)
ATTITUDE_FRAMES = ('body', 'inertial')  # the frames of an attitude's error (attitude_errors)

__all__ = ['ATTITUDE_FRAMES', 'MIN_RUN_SAMPLES', 'check_run_length', 'EstimationFilter', 'FilterBase',
           'REJECTION_KINDS', 'RejectedRun', 'STATE_CHANGING_KINDS', 'UPDATE_KINDS', 'UpdateResult',
           'attitude_errors', 'attitude_innovation', 'fold_attitude_error', 'new_counts', 'kalman_update_first_three',
           'quadratic_fit_chi2']


@dataclasses.dataclass(frozen=True, eq=False)
class UpdateResult:
    """The outcome of one measurement (module doc).

    Attributes:
        kind: one of UPDATE_KINDS.
        t: the measurement stamp [s] (as given, also when rejected).
        nis: normalized innovation squared y' S^-1 y (nan when not computed).
        reason: one line naming the value behind a rejection or reset ('' when accepted).
        innovation: y = z - h(x) in the filter's measurement units and axes, or None where none was
            computed (initialized, non_finite, non_unit, stale).

    Compared by identity (it may hold an array).
    """

    kind: str
    t: float
    nis: float = math.nan
    reason: str = ''
    innovation: np.ndarray = None

    def __post_init__(self):
        if self.kind not in UPDATE_KINDS:
            raise ValueError(f'UpdateResult kind {self.kind!r} is not one of {UPDATE_KINDS}')

    @property
    def accepted(self):
        """True if the measurement changed the state (initialized, accepted, reset)."""
        return self.kind in STATE_CHANGING_KINDS


def kalman_update_first_three(x, p, y, r):
    """The gate's figure and the Kalman update for a measurement of the first three states, H = [I 0].

    S = H P H' + R = P[:3, :3] + R is inverted once for both: NIS = y' S^-1 y, K = P H' S^-1,
    x + K y and the Joseph form P = (I - K H) P (I - K H)' + K R K', which stays symmetric positive
    semi-definite whatever the rounding in K. The same arithmetic as filterpy's KalmanFilter.update,
    without its bookkeeping (a third of a filter cycle).

    Args:
        x: state (6, 1); p: its covariance (6, 6); y: innovation z - H x (3,); r: measurement covariance (3, 3).

    Returns:
        (NIS, x + K y (6, 1), P after the update). Both filters gate on the NIS before taking the rest.
    """
    # The products are ndarray.dot, the BLAS calls of @ and of filterpy's dot (the same bits) at half the cost of @
    # per call on these sizes; the inverse is np.linalg.inv's LAPACK call without its checks (a third of its cost).
    s = p[:3, :3] + r
    s_inv = _inverse(s, signature='d->d')
    nis = float(y.dot(s_inv).dot(y))
    if not math.isfinite(nis):
        s_inv = np.linalg.inv(s)  # a singular S raises LinAlgError here, as it always did
        nis = float(y.dot(s_inv).dot(y))
    k = p[:, :3].dot(s_inv)
    eye, eye_first_three = _identity(p.shape[0])
    i_kh = eye.copy()
    i_kh[:, :3] = eye_first_three - k  # I - K H (a contiguous subtraction: the strided one costs twice as much)
    return nis, x + k.dot(y[:, None]), i_kh.dot(p).dot(i_kh.T) + k.dot(r).dot(k.T)


def _identity(n):
    """The n x n identity and its first three columns (contiguous), kept (np.eye costs 8x a copy)."""
    if n not in _IDENTITY:
        eye = np.eye(n)
        _IDENTITY[n] = eye, np.ascontiguousarray(eye[:, :3])
    return _IDENTITY[n]


def attitude_innovation(q_ref, q_meas):
    """nu = log(q_ref^-1 * q_meas) [rad]: the measured attitude error as a rotation vector in the reference's
    body axes (q_meas = q_ref * exp(nu)); both quaternions (x, y, z, w) of the body in the same frame.
    With q_true = q_ref * exp(dtheta) and a body-frame measurement error, H = [I 0] for dtheta."""
    return rotation_vector_from_quat(quat_multiply(quat_conjugate(q_ref), q_meas))


def attitude_errors(q_ref, q_meas):
    """A rejected attitude's errors in the run's frames, ATTITUDE_FRAMES (module doc): (body q_ref^-1 q_meas,
    inertial q_meas q_ref^-1), unit quaternions (x, y, z, w); q_ref and q_meas both q_eci_from_body."""
    q_ref_inv = quat_conjugate(q_ref)
    return quat_multiply(q_ref_inv, q_meas), quat_multiply(q_meas, q_ref_inv)


def quadratic_fit_chi2(times_s, errors, sigma):
    """Chi-square of the residuals of the least-squares quadratic in time fitted to each axis of errors (N, 3)
    at times_s (N,) [s], in units of sigma (the errors' unit): sum over samples and axes of (residual / sigma)^2.
    Times are centred and scaled to the run's span for a well-conditioned fit."""
    tau = np.asarray(times_s, dtype=float)
    tau = tau - tau.mean()
    span_s = float(np.ptp(tau))
    if span_s > 0.0:
        tau = tau / span_s
    h = np.vander(tau, 3)  # [tau^2, tau, 1]
    coefficients = np.linalg.lstsq(h, errors, rcond=None)[0]
    residuals = errors - h.dot(coefficients)
    return float(np.einsum('ij,ij->', residuals, residuals)) / sigma ** 2


class RejectedRun:
    """The current run of consecutive gate rejections and the restart rule (module doc).

    Args:
        length: N, the samples kept and tested (``max_consecutive_outliers``), >= MIN_RUN_SAMPLES.
        sigma: the measurement's 1-sigma per axis (its unit: m, or rad for a rotation).
        probability: the gate's probability, the agreement test's chi-square quantile.
        frames: the names of the frames each sample's error is given in (``add``).
        rotation: True when the errors are unit quaternions (fitted as log(E_m^-1 E_k)), False for 3-vectors.
    """

    def __init__(self, length, sigma, probability, frames, rotation):
        self.length = check_run_length(length)
        self._sigma = float(sigma)
        self._frames = tuple(frames)
        self._rotation = rotation
        self.threshold = float(chi2.ppf(probability, df=3 * (self.length - 3)))
        self._times_s = collections.deque(maxlen=self.length)
        self._errors = collections.deque(maxlen=self.length)  # per sample: its error in each frame
        self.agreement = ''  # the frame that agreed and its chi-square, once add returned True

    def clear(self):
        """End the run (a sample inside the gate, or a (re)initialization)."""
        self._times_s.clear()
        self._errors.clear()

    def add(self, t, errors):
        """Keep one rejected sample stamped t [s], its error in each frame; True when the last N kept agree."""
        self._times_s.append(float(t))
        self._errors.append(tuple(errors))
        if len(self._times_s) < self.length:
            return False
        for i, frame in enumerate(self._frames):
            run = [e[i] for e in self._errors]
            chi_square = quadratic_fit_chi2(self._times_s, _rotation_offsets(run) if self._rotation else
                                            np.array(run), self._sigma)
            if chi_square <= self.threshold:
                self.agreement = (f'agreeing in the {frame} frame (quadratic fit chi2 {chi_square:.4g} <= '
                                  f'{self.threshold:.4g})')
                return True
        return False


def _rotation_offsets(errors):
    """log(E_m^-1 E_k) [rad] (N, 3) of unit quaternions E, m the middle one (module doc)."""
    middle_inv = quat_conjugate(errors[len(errors) // 2])
    return np.array([rotation_vector_from_quat(quat_multiply(middle_inv, e)) for e in errors])


def fold_attitude_error(q_ref, dtheta, p):
    """The reset of a multiplicative filter after an update (Markley): the estimated body-frame error
    dtheta [rad] folded into the reference, q <- q * exp(dtheta), and the covariance of the new error
    dtheta' = G (dtheta - dtheta_hat), G = I - 1/2 [dtheta_hat x] on the attitude block, P <- G P G'.

    Args:
        q_ref: reference quaternion (x, y, z, w); dtheta: (3,) the update's attitude correction; p: the
            covariance after the update (n, n), the first three states the attitude error.

    Returns:
        (unit q_ref * exp(dtheta), G P G' made exactly symmetric). The other states' corrections are the
        caller's to add (they are additive).
    """
    q = quat_normalize(quat_multiply(q_ref, quat_from_rotation_vector(dtheta)))
    g = np.eye(p.shape[0])
    g[:3, :3] -= 0.5 * skew(dtheta)
    p = g @ p @ g.T  # P = G P G'
    return q, 0.5 * (p + p.T)


def new_counts():
    """A count of 0 for every kind of UPDATE_KINDS, the ``counts`` dict of a filter."""
    return dict.fromkeys(UPDATE_KINDS, 0)


class FilterBase:
    """What the filters keep the same way: the filter time, the chi-square(3) innovation gate of
    gate_probability on the normalized innovation squared, the run of rejected samples and its restart rule
    (``RejectedRun``, with measurement_sigma, frames and rotation; None without measurement_sigma: a filter that
    never calls _gate_verdict), and the count of every outcome kind."""

    def __init__(self, gate_probability, max_consecutive_outliers, measurement_sigma=None, frames=(),
                 rotation=False):
        self._t = None
        self._gate = float(chi2.ppf(gate_probability, df=3))
        self._rejected = None if measurement_sigma is None else RejectedRun(
            max_consecutive_outliers, measurement_sigma, gate_probability, frames, rotation)
        self.counts = new_counts()

    def _gate_verdict(self, nis, t, errors):
        """The one rejection rule: 'pass' inside the gate (the rejected run ends), else 'reset' when the rejected
        run with this sample agrees (its reason in ``_rejected.agreement``), else 'outlier' (module doc).
        errors: a callable giving this sample's error in each of the run's frames (called only when rejected)."""
        if nis <= self._gate:
            self._rejected.clear()
            return 'pass'
        return 'reset' if self._rejected.add(t, errors()) else 'outlier'

    def _outcome(self, kind, t, nis=math.nan, reason='', innovation=None, counts=None):
        """The UpdateResult of one measurement, counted by kind in ``counts`` (default self.counts)."""
        (self.counts if counts is None else counts)[kind] += 1
        return UpdateResult(kind, float(t), nis, reason, innovation)

    def _finite_measurement(self, t, value, size, what='measurement', counts=None):
        """(value as a float array (size,), None), or (None, the counted 'non_finite' UpdateResult) when t
        is not a finite number or value is not ``size`` finite numbers (also when either is not numeric)."""
        t_s = _float_or_nan(t)
        try:
            z = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            z = None
        if not (math.isfinite(t_s) and z is not None and z.shape == (size,) and all(map(math.isfinite, z.tolist()))):
            return None, self._outcome('non_finite', t_s, reason=f'{what} at t = {t!r} s is not a finite stamp and '
                                                                 f'{size} finite numbers: {value!r}', counts=counts)
        return z, None

    def _unit_quaternion_measurement(self, t, q, norm_tolerance, what='measurement', counts=None):
        """(q scaled to unit norm, None), or (None, the counted rejection): 'non_finite' as
        _finite_measurement, 'non_unit' when |norm - 1| > norm_tolerance."""
        z, rejected = self._finite_measurement(t, q, 4, what, counts)
        if rejected is not None:
            return None, rejected
        norm = float(np.linalg.norm(z))
        if abs(norm - 1.0) > norm_tolerance:
            return None, self._outcome('non_unit', t, reason=f'{what} at t = {t} s has norm {norm:.6g}, not within '
                                                             f'{norm_tolerance} of 1', counts=counts)
        return z / norm, None

    def _stale_measurement(self, t, t_filter, what='measurement', counts=None):
        """The counted 'stale' UpdateResult if the stamp t is before t_filter (equal is not stale), else None."""
        if t_filter is not None and t < t_filter:
            return self._outcome('stale', t, reason=f'{what} stamped t = {t} s is before the filter time '
                                                    f'{t_filter} s', counts=counts)
        return None

    @property
    def initialized(self):
        return self._t is not None

    @property
    def t(self):
        """Filter time [s] (None before initialization)."""
        return self._t

    @property
    def gate_threshold(self):
        """Normalized innovation squared above which a measurement is an outlier."""
        return self._gate


def _float_or_nan(t):
    """t as a float, nan when it is not a number."""
    try:
        return float(t)
    except (TypeError, ValueError):
        return math.nan


@runtime_checkable
class EstimationFilter(Protocol):
    """The verbs both estimation filters share (module doc)."""

    counts: dict

    @property
    def initialized(self):
        """True once a measurement (or an explicit initialization) has set the state."""

    @property
    def t(self):
        """Filter time [s], None before initialization."""

    @property
    def gate_threshold(self):
        """Normalized innovation squared above which a measurement is an outlier."""

    def update(self, t, z):
        """Process the measurement z stamped t [s]; returns an UpdateResult."""

    def propagate_to(self, t):
        """Time update to t >= the filter time [s], in place."""

    def predict(self, t):
        """The state predicted to t >= the filter time [s]; the filter is unchanged."""

    def state(self):
        """The state at the filter time."""
