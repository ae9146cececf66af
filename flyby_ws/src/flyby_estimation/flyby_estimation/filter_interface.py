"""What the two estimation filters have in common: the outcome of a measurement and the verbs (no ROS).

``relative_nav.RelativeNavFilter`` (chaser position) and ``target_filter.TargetAttitudeFilter``
(target attitude) both follow ``EstimationFilter``:

- ``update(t, z)`` processes one measurement and returns an ``UpdateResult``; it does not raise for a
  bad measurement. Every outcome is counted by kind in ``counts``.
- ``propagate_to(t)`` is the time update: the filter moves to t (later measurements stamped before t
  are then 'stale').
- ``predict(t)`` returns the state predicted to t and leaves the filter unchanged.
- ``state()`` returns the state at the filter time ``t``.

Outcome kinds: 'initialized' (the first measurement set the state), 'accepted' (fused), 'reset'
(lost: the ``max_consecutive_outliers``-th consecutive outlier restarts the filter from that
measurement), or a rejection, which leaves the state unchanged: 'non_finite' (not a finite stamp
and the right number of finite values), 'non_unit' (a quaternion far from unit norm), 'stale'
(stamped before the filter time), 'outlier' (normalized innovation squared above the chi-square
gate; the filter has then been propagated to the stamp).

Helpers the filters share: ``kalman_update_first_three`` (the gated Joseph-form update for H = [I 0]);
``FilterBase`` (filter time, gate, outcome counts, and the checks of a measurement's stamp and
values that name the rejection); for the multiplicative attitude filters, whose error state starts
with the body-frame rotation vector dtheta (q_true = q_ref * exp(dtheta), quaternions (x, y, z, w)),
``attitude_innovation`` and ``fold_attitude_error`` (the reset of the estimated error into the
reference, Markley's reset Jacobian).
"""

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

__all__ = ['EstimationFilter', 'FilterBase', 'REJECTION_KINDS', 'STATE_CHANGING_KINDS', 'UPDATE_KINDS', 'UpdateResult',
           'attitude_innovation', 'fold_attitude_error', 'new_counts', 'kalman_update_first_three']


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
    """What both filters keep the same way: the filter time, the chi-square(3) innovation gate of
    gate_probability on the normalized innovation squared, and the count of every outcome kind."""

    def __init__(self, gate_probability, max_consecutive_outliers):
        self._t = None
        self._gate = float(chi2.ppf(gate_probability, df=3))
        self._max_outliers = max_consecutive_outliers
        self._consecutive_outliers = 0
        self.counts = new_counts()

    def _gate_verdict(self, nis):
        """The one rejection rule: 'pass' inside the gate, else 'outlier', or 'reset' at the
        max_consecutive_outliers-th consecutive outlier (module doc)."""
        if nis <= self._gate:
            self._consecutive_outliers = 0
            return 'pass'
        self._consecutive_outliers += 1
        return 'reset' if self._consecutive_outliers >= self._max_outliers else 'outlier'

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
