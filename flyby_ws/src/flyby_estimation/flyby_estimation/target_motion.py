"""The target's attitude motion predicted (seed 000 eq 4, 6-9): the state at a time with its covariance, a body
point's position and velocity in hill with their Jacobian, and a prediction over a horizon asked at many times.

Pure numpy/scipy, no ROS. The target attitude filter (``target_filter``) and the planner use it. Conventions and
the error state [dtheta_body, domega_body] are those of ``attitude_error_dynamics`` (``ErrorStateDynamics``).
"""

import dataclasses
import math

import numpy as np
from scipy.integrate import DOP853, OdeSolution
from scipy.integrate._ivp.rk import Dop853DenseOutput

from flyby_estimation.quaternion_floats import float_list, q_eci_from_hill_floats, quat_exp_floats, quat_product_floats
from flyby_sim.dynamics.attitude import body_point_state
from flyby_sim.dynamics.orbital import eci_vector_in_hill, q_eci_from_body
from flyby_sim.dynamics.rotation import quat_normalize, quat_to_matrix, quat_to_matrix_many, skew


def orbit_rate_hill(n):
    """Omega^H = [0, -n, 0] [rad/s]: the hill frame's inertial angular velocity in hill axes, seed 000 eq 11."""
    return np.array((0.0, -n, 0.0))


def covariance_in_hill(c_hill_from_body, omega_body, covariance_body):
    """The error covariance in hill axes: of [dtheta_hill, domega_hill] from [dtheta_body, domega_body].

    dtheta_hill = C dtheta_body (q_ref * exp(dtheta_b) = exp(C dtheta_b) * q_ref), and
    omega_hill = C omega_body (eq 6) varies as d(omega_hill) = C (-[omega x] dtheta_body + domega_body)
    because C_true = C (I + [dtheta x]).
    """
    c = np.asarray(c_hill_from_body, dtype=float)
    j = np.zeros((6, 6))
    j[:3, :3] = c
    j[3:, :3] = (-c).dot(skew(omega_body))
    j[3:, 3:] = c
    return j.dot(covariance_body).dot(j.T)  # ndarray.dot: @'s BLAS products at half their cost per call


def body_point_in_hill(c_hill_from_body, omega_body, x_body, n):
    """Position and velocity of a body-fixed point in hill and their Jacobian, seed 000 eq 8-9.

    Eq 8: x_g^H = C_I^H C_B^I x_g^B + C_I^H x_T^I. Our hill frame is centred on the target's centre
    of mass (DESIGN §3), so the second term (the target's own position in hill) is zero.

    Eq 9 as printed has the wrong sign on the orbital-rate term for a velocity relative to the
    rotating hill frame (the velocity the chaser must match, DESIGN §3): v_g^H = (omega^H - Omega^H) x x_g^H
    (flyby_sim.dynamics.attitude.body_point_state, which computes both;
    test_target_motion.py::test_seed000_eq9_sign_by_numerical_derivative settles the sign).

    Args:
        c_hill_from_body: rotation matrix of q_hill_from_body.
        omega_body: inertial angular velocity, body axes [rad/s].
        x_body: the point in body axes [m] (e.g. the grasp point).
        n: orbital mean motion [rad/s].

    Returns:
        (r_hill [m], v_hill [m/s] relative to the rotating hill frame, J) with J the 6x6 Jacobian of
        [r_hill; v_hill] with respect to the error state [dtheta_body; domega_body].
    """
    r_hill, v_hill = body_point_state(c_hill_from_body, omega_body, x_body, n)  # eq 8-9
    c = np.asarray(c_hill_from_body, dtype=float)
    x_b = np.asarray(x_body, dtype=float)
    wx_b = np.cross(np.asarray(omega_body, dtype=float), x_b)
    big_omega_x = skew(orbit_rate_hill(n))
    c_xb = c @ skew(x_b)
    j = np.zeros((6, 6))
    j[:3, :3] = -c_xb  # C [dtheta x] x_b = -C [x_b x] dtheta
    j[3:, :3] = -c @ skew(wx_b) + big_omega_x @ c_xb
    j[3:, 3:] = -c_xb
    return r_hill, v_hill, j


class PredictedState:
    """The target's attitude motion predicted to time t (or the filter's estimate at t).

    Attributes:
        t: sim time [s].
        q_hill_from_body, q_eci_from_body: attitude (x, y, z, w).
        omega_body: inertial angular velocity in body axes [rad/s] (odometry twist.angular).
        omega_hill: the same vector in hill axes, seed 000 eq 6 (inertial rate, not relative to hill).
        covariance: 6x6 (None for a prediction without covariance) of the error state
            [dtheta_body, domega_body] [rad^2, rad^2/s, rad^2/s^2].
        covariance_hill: 6x6 of [dtheta_hill, domega_hill] (covariance_in_hill). For a
            nav_msgs/Odometry with frame hill and child target_body: pose orientation covariance =
            covariance_hill[:3, :3] (rotation about hill axes), twist angular covariance =
            covariance[3:, 3:] (body axes, as twist is in child_frame_id).

    The covariance may be given as a function of no argument that returns it (``MotionPrediction.state``:
    most of its states are asked only for the motion, by the planner's and guidance's scans); it is then
    computed at its first use, and covariance_hill (given or not) at its own. Read-only by convention.
    """

    __slots__ = ('t', 'q_hill_from_body', 'q_eci_from_body', 'omega_body', 'omega_hill', '_covariance',
                 '_covariance_hill', '_c_hill_from_body')

    def __init__(self, t, q_hill_from_body, q_eci_from_body, omega_body, omega_hill, covariance, covariance_hill=None,
                 c_hill_from_body=None):
        self.t = t
        self.q_hill_from_body = q_hill_from_body
        self.q_eci_from_body = q_eci_from_body
        self.omega_body = omega_body
        self.omega_hill = omega_hill
        self._covariance = covariance
        self._covariance_hill = covariance_hill
        self._c_hill_from_body = c_hill_from_body

    @property
    def covariance(self):
        if callable(self._covariance):
            self._covariance = self._covariance()
        return self._covariance

    @property
    def covariance_hill(self):
        if self._covariance_hill is None and self.covariance is not None:
            c = self._c_hill_from_body
            self._covariance_hill = covariance_in_hill(quat_to_matrix(self.q_hill_from_body) if c is None else c,
                                                       self.omega_body, self._covariance)
        return self._covariance_hill

    def __repr__(self):
        return (f'PredictedState(t={self.t!r}, q_hill_from_body={self.q_hill_from_body!r}, q_eci_from_body='
                f'{self.q_eci_from_body!r}, omega_body={self.omega_body!r}, omega_hill={self.omega_hill!r}, '
                f'covariance={self.covariance!r}, covariance_hill={self.covariance_hill!r})')


@dataclasses.dataclass(frozen=True)
class BodyPointPrediction:
    """A body-fixed point in hill at time t (seed 000 eq 8-9) with its 6x6 covariance of [r_hill; v_hill]."""

    t: float
    r_hill: np.ndarray  # [m], from the target's centre of mass
    v_hill: np.ndarray  # [m/s], relative to the rotating hill frame (= d r_hill / dt)
    covariance: np.ndarray  # [m^2, m^2/s, m^2/s^2]


def make_state(t, n, q_eci_from_body_, omega_body, covariance, symmetric=False):
    """PredictedState from the inertial reference state and error covariance (or None) at t.

    The covariance is made exactly symmetric, 0.5 (P + P'), unless ``symmetric`` says it is already (that
    would give it back unchanged, to the bit); it may then also be a function that returns it, called at its
    first use (PredictedState).
    """
    if covariance is not None and not symmetric:
        covariance = 0.5 * (covariance + covariance.T)
    x, y, z, w = q_eci_from_hill_floats(t, n)
    q_hb = quat_product_floats((-x, -y, -z, w), float_list(q_eci_from_body_))  # orbital.q_hill_from_body
    c = quat_to_matrix(q_hb)
    omega = np.array(omega_body, dtype=float)
    return PredictedState(float(t), np.array(q_hb), np.array(q_eci_from_body_), omega, c @ omega, covariance, None, c)


def point_prediction(state, x_body, n):
    """BodyPointPrediction of x_body [m, body axes] from a PredictedState (seed 000 eq 8-9).

    The covariance is None when the state has none (a MotionPrediction without covariance).
    """
    c = quat_to_matrix(state.q_hill_from_body)
    r, v, j = body_point_in_hill(c, state.omega_body, x_body, n)
    cov = None if state.covariance is None else j @ state.covariance @ j.T
    return BodyPointPrediction(t=state.t, r_hill=r, v_hill=v, covariance=cov)


@dataclasses.dataclass(frozen=True)
class PointTrack:
    """A body point over many times (vectorized eq 8-9): t (N,), r_hill (N, 3) [m],
    v_hill (N, 3) [m/s] relative to hill, omega_hill (N, 3) [rad/s] (eq 6)."""

    t: np.ndarray
    r_hill: np.ndarray
    v_hill: np.ndarray
    omega_hill: np.ndarray


def dop853_reference(dynamics, t0, t_end, y0, rtol, atol):
    """solve_ivp(dynamics.reference_rate, (t0, t_end), y0, method='DOP853', rtol, atol, dense_output=True):
    (sol.sol, sol.y), the same steps and dense output to the bit (test_dop853_reference_is_solve_ivps_to_the_bit).

    solve_ivp's loop for this case (no t_eval, no events), with scipy's DOP853 stepping; the solver calls the
    reference rate directly rather than through its two wrappers (np.asarray of an array it already has and a
    count of the calls), which cost a third of the rate itself at 15 calls a step. RuntimeError if DOP853 fails.
    """
    rate = dynamics.reference_rate_floats
    solver = DOP853(dynamics.reference_rate, float(t0), y0, float(t_end), rtol=rtol, atol=atol)
    solver.fun = lambda t, y: np.array(rate(y.tolist()))  # what the wrappers return, without them
    ts, ys, segments = [float(t0)], [y0], []
    while solver.status == 'running':
        message = solver.step()
        if solver.status == 'failed':
            raise RuntimeError(f'attitude prediction to t = {t_end} s failed: {message}')
        segments.append(solver.dense_output())
        if len(ts) > 1 and ts[-1] == solver.t:  # solve_ivp keeps no empty step
            segments.pop()
        else:
            ts.append(solver.t)
            ys.append(solver.y)
    return OdeSolution(ts, segments), np.vstack(ys).T


class DenseSolution:
    """A DOP853 dense solution (scipy's OdeSolution) evaluated at many times at once.

    scipy evaluates an array of times segment by segment, a dozen numpy calls per segment the times fall in: a
    prediction's covariance asks for a few hundred times spread over a hundred segments. This takes, per time,
    the segment scipy would take (the lower one at a step, OdeSolution's rule) and runs Dop853DenseOutput's
    arithmetic on all times at once: the same operations on each element, hence the same values to the bit
    (test_dense_solution_is_scipys_to_the_bit). A single time, or a solution of another kind, is left to scipy.
    """

    def __init__(self, ode_solution):
        self._solution = ode_solution
        self._segments = None  # (t_old, h, F reversed, y_old) of every segment, gathered at the first array call
        self._own = (ode_solution.ascending and ode_solution.side == 'left'
                     and all(type(i) is Dop853DenseOutput for i in ode_solution.interpolants))

    def __call__(self, t):
        t = np.asarray(t)
        solution = self._solution
        if t.ndim != 1 or not t.size or not self._own:
            return solution(t)
        if self._segments is None:
            segments = solution.interpolants
            self._segments = (np.array([s.t_old for s in segments]), np.array([s.h for s in segments]),
                              np.array([s.F[::-1] for s in segments]), np.array([s.y_old for s in segments]))
        t_old, h, f_reversed, y_old = self._segments
        k = np.searchsorted(solution.ts_sorted, t, side='left') - 1  # OdeSolution.__call__'s choice
        np.clip(k, 0, solution.n_segments - 1, out=k)
        x = ((t - t_old[k]) / h[k])[:, None]  # Dop853DenseOutput._call_impl, on every time at once
        f = f_reversed[k]
        y = np.zeros((t.size, y_old.shape[1]))
        for i in range(f.shape[1]):
            y += f[:, i]
            if i % 2 == 0:
                y *= x
            else:
                y *= 1 - x
        y += y_old[k]
        return y.T.copy()  # (states, times), C-contiguous as scipy's


class MotionPrediction:
    """Dense prediction of the target's attitude motion over [t0, t_end] (seed 000 eq 4, 6-9).

    One DOP853 integration of the reference state; ``state(t)`` and ``body_point_in_hill(x_body, t)``
    then answer at any t in the interval from the dense output without integrating again, and
    ``track(x_body, times)`` answers for many times at once (for a planner scanning candidate grasp
    times).

    The covariance P(t) = Phi P0 Phi' + Qd is built at its first use, not with the motion: the interval
    is cut into equal substeps that turn the body by at most max_step_angle_rad (and last at most
    max_step_s); Phi and Qd of each come in closed form from the dense reference rates at its ends
    (``ErrorStateDynamics.substep_transition_many``) and are chained into P at the substep ends,
    P_k+1 = Phi_k P_k Phi_k' + Qd_k. Between two ends P is the cubic Hermite interpolant of P and
    dP/dt = F P + P F' + G Qc G' there (error h^4/384 max|d^4P/dt^4|, ~(angle)^4/24 of |P| for the
    rotating attitude block). Against DOP853 of the 79 augmented states (4x the cost of the reference
    alone) the attitude sigma agrees to 3e-5 relative over 600 s of the 21 deg/s seed 001 tumbler
    (test_lazy_covariance_matches_dop853_of_the_augmented_state).

    Args:
        dynamics: ErrorStateDynamics.
        n: orbital mean motion [rad/s].
        t0, q_eci_from_body0, omega_body0, covariance0: the estimate at t0 (error-state covariance 6x6).
        t_end: last time of interest [s], >= t0.
        rtol, atol: DOP853 tolerances; the default keeps a 600 s prediction of the 21 deg/s seed 001
            tumbler within 1e-8 rad of flyby_sim's reference integration (rtol 1e-13), far below
            the estimation error.
        with_covariance: False makes a prediction without covariance (states then carry covariance
            None); covariance0 may then be None. The motion is the same either way.
        max_step_angle_rad, max_step_s: substep limits of the covariance (above).
    """

    def __init__(self, dynamics, n, t0, q_eci_from_body0, omega_body0, covariance0, t_end,
                 rtol=1e-9, atol=1e-12, with_covariance=True, max_step_angle_rad=0.15, max_step_s=10.0):
        if not (math.isfinite(t_end) and t_end >= t0):
            raise ValueError(f't_end = {t_end} s must be finite and >= t0 = {t0} s')
        self.t0 = float(t0)
        self.t_end = float(t_end)
        self._n = n
        self._dynamics = dynamics
        self._p0 = np.array(covariance0, dtype=float) if with_covariance else None
        self._max_step_angle_rad = max_step_angle_rad
        self._max_step_s = max_step_s
        self._nodes = None  # (substep ends, P, dP/dt there), built at the first use of the covariance
        self._blocks = {}  # block.indices(6) -> (P, dP/dt) of that block at the nodes
        y0 = np.concatenate((q_eci_from_body0, omega_body0), dtype=float)
        if t_end > t0:
            solution, y_steps = dop853_reference(dynamics, self.t0, self.t_end, y0, rtol, atol)
            self._dense = DenseSolution(solution)
            self._rate_max = float(np.linalg.norm(y_steps[4:7], axis=0).max())  # at DOP853's steps
        else:
            self._dense = lambda t: np.repeat(y0[:, None], np.size(t), axis=1) if np.ndim(t) else y0

    @classmethod
    def from_dense(cls, dynamics, n, t0, t_end, dense):
        """A prediction without covariance whose motion is ``dense``: t -> [q_eci_from_body; omega_body] (7,) or
        (7, N) for times (N,) (perturbed_predictions)."""
        self = cls.__new__(cls)
        self.t0, self.t_end, self._n, self._dynamics = float(t0), float(t_end), n, dynamics
        self._p0, self._dense = None, dense
        return self

    def state(self, t):
        """PredictedState at t [s] in [t0, t_end]; its covariance is computed at its first use."""
        if not (self.t0 <= t <= self.t_end):
            raise ValueError(f't = {t} s is outside the predicted interval [{self.t0}, {self.t_end}] s')
        y = self._dense(t)
        return make_state(t, self._n, quat_normalize(y[:4].tolist()), y[4:7],
                          None if self._p0 is None else lambda: self._symmetric_covariance(t), symmetric=True)

    def _symmetric_covariance(self, t):
        p = self._covariance(np.array((t,), dtype=float), slice(None))[0]
        return 0.5 * (p + p.T)

    @property
    def has_covariance(self):
        return self._p0 is not None

    def attitude_sigma_rad(self, times):
        """(N,) 1-sigma attitude error [rad] at the times (N,) [s]: the square root of the largest eigenvalue of
        the attitude block of P(t) = Phi P0 Phi' + Qd. Needs a prediction with covariance."""
        if self._p0 is None:
            raise ValueError('this prediction carries no covariance')
        p = self._covariance(np.atleast_1d(np.asarray(times, dtype=float)), slice(3))
        return np.sqrt(np.maximum(np.linalg.eigvalsh(0.5 * (p + np.swapaxes(p, 1, 2)))[:, -1], 0.0))

    def _covariance(self, t, block):
        """(N, b, b) block [block, block] of P at the times t (N,) in [t0, t_end] (class doc)."""
        if self.t_end == self.t0:
            return np.broadcast_to(self._p0[block, block], (t.size,) + self._p0[block, block].shape)
        if self._nodes is None:
            self._nodes = self._covariance_nodes()
        nodes = self._nodes[0]
        key = block.indices(6)
        if key not in self._blocks:  # the block of P and dP/dt at every node, contiguous: gathered per time below
            self._blocks[key] = tuple(np.ascontiguousarray(a[:, block, block]) for a in self._nodes[1:])
        p, p_dot = self._blocks[key]
        k = np.minimum(np.searchsorted(nodes, t, side='right') - 1, nodes.size - 2)
        h = (nodes[k + 1] - nodes[k])[:, None, None]
        s = (t - nodes[k])[:, None, None] / h
        s2 = s * s
        # cubic Hermite basis on [0, 1]: h00, h10, h01, h11
        h00, h10, h01, h11 = 1.0 - 3.0 * s2 + 2.0 * s2 * s, s - 2.0 * s2 + s2 * s, 3.0 * s2 - 2.0 * s2 * s, s2 * s - s2
        return h00 * p[k] + (h10 * h) * p_dot[k] + h01 * p[k + 1] + (h11 * h) * p_dot[k + 1]

    def _covariance_nodes(self):
        """(substep ends (M+1,), P there (M+1, 6, 6), dP/dt there (M+1, 6, 6)) over [t0, t_end] (class doc)."""
        dyn = self._dynamics
        span = self.t_end - self.t0
        steps = max(1, math.ceil(span * self._rate_max / self._max_step_angle_rad), math.ceil(span / self._max_step_s))
        nodes = np.linspace(self.t0, self.t_end, steps + 1)
        w = self._dense(nodes)[4:7].T
        phi, qd = dyn.substep_transition_many(w[:-1], w[1:], np.diff(nodes))
        p_k = self._p0
        chained = [p_k]
        for phi_k, qd_k in zip(phi, qd, strict=True):
            p_k = phi_k.dot(p_k).dot(phi_k.T) + qd_k  # P_k+1 = Phi_k P_k Phi_k' + Qd_k (ndarray.dot: @'s product)
            chained.append(p_k)
        p = np.array(chained)
        fp = dyn.jacobian_many(w) @ p
        return nodes, p, fp + np.swapaxes(fp, 1, 2) + dyn.noise_density  # dP/dt = F P + P F' + G Qc G'

    def body_point_in_hill(self, x_body, t):
        """BodyPointPrediction of the body point x_body [m] at t [s] (seed 000 eq 8-9)."""
        return point_prediction(self.state(t), x_body, self._n)

    def track(self, x_body, times):
        """PointTrack of the body point x_body [m] at the times (N,) [s], without covariance.

        Eq 8-9 evaluated for all times at once (flyby_sim.dynamics.attitude.body_point_state on the
        stack of C_hill_from_body).
        """
        t = np.atleast_1d(np.asarray(times, dtype=float))
        if t.size and not (self.t0 <= t.min() and t.max() <= self.t_end):
            raise ValueError(f'times [{t.min()}, {t.max()}] s leave the predicted interval [{self.t0}, {self.t_end}] s')
        y = self._dense(t)
        c_hill_from_body = self._c_hill_from_body(t, y)
        w_body = y[4:7].T
        r_hill, v_hill = body_point_state(c_hill_from_body, w_body, x_body, self._n)  # eq 8-9
        omega_hill = np.einsum('nij,nj->ni', c_hill_from_body, w_body)  # eq 6
        return PointTrack(t=t, r_hill=r_hill, v_hill=v_hill, omega_hill=omega_hill)


    def c_hill_from_body(self, times):
        """(N, 3, 3) rotation matrices hill <- body at the times (N,) [s] in the predicted interval."""
        t = np.atleast_1d(np.asarray(times, dtype=float))
        if t.size and not (self.t0 <= t.min() and t.max() <= self.t_end):
            raise ValueError(f'times [{t.min()}, {t.max()}] s leave the predicted interval [{self.t0}, {self.t_end}] s')
        return self._c_hill_from_body(t, self._dense(t))

    def _c_hill_from_body(self, t, y):
        body_axes_eci = np.swapaxes(quat_to_matrix_many(y[:4].T), 1, 2)  # row k: body axis k in ECI
        # C_hill_from_body = C_hill_from_eci(t) C_eci_from_body: the body axes seen in hill at their time.
        return np.swapaxes(eci_vector_in_hill(body_axes_eci, t[:, None], self._n), 1, 2)


def perturbed_predictions(dynamics, n, t0, q_eci_from_body0, omega_body0, errors, t_end, rtol=1e-8, atol=1e-10):
    """MotionPredictions (without covariance) of the estimate at t0 with each error state added, one per row of
    errors (K, 6) = [dtheta_body, domega_body] (q = q_ref * exp(dtheta), omega = omega_ref + domega, the filter's
    convention): the true motions an estimate's covariance allows (its sigma points), integrated as one DOP853
    system of the K torque-free states (seed 000 eq 4), which costs about one prediction."""
    errors = np.atleast_2d(np.asarray(errors, dtype=float))
    if not (math.isfinite(t_end) and t_end > t0):
        raise ValueError(f't_end = {t_end} s must be finite and > t0 = {t0} s')
    count = len(errors)
    q0 = float_list(q_eci_from_body0)
    y0 = np.array([quat_product_floats(q0, quat_exp_floats(float_list(e[:3]))) + tuple(np.asarray(omega_body0) + e[3:])
                   for e in errors]).T  # (7, K): row i holds component i of every state
    inertia, inertia_inv = dynamics.inertia, dynamics.inertia_inv

    def stacked(t, y):
        """dq/dt = 1/2 q * (omega, 0), domega/dt = -I^-1 (omega x I omega) of every state at once."""
        y = y.reshape(7, count)
        x, y_, z, w = y[:4]
        wx, wy, wz = omega = y[4:]
        h = inertia @ omega
        q_dot = 0.5 * np.array((w * wx + y_ * wz - z * wy, w * wy + z * wx - x * wz, w * wz + x * wy - y_ * wx,
                                -(x * wx + y_ * wy + z * wz)))
        omega_dot = inertia_inv @ -np.array((wy * h[2] - wz * h[1], wz * h[0] - wx * h[2], wx * h[1] - wy * h[0]))
        return np.concatenate((q_dot, omega_dot)).ravel()
    solver = DOP853(stacked, float(t0), y0.ravel(), float(t_end), rtol=rtol, atol=atol)
    ts, segments = [float(t0)], []
    while solver.status == 'running':
        message = solver.step()
        if solver.status == 'failed':
            raise RuntimeError(f'perturbed attitude predictions to t = {t_end} s failed: {message}')
        segments.append(solver.dense_output())
        ts.append(solver.t)
    out = []
    for k in range(count):  # each motion its own dense output: its components of every step's interpolant
        own = [Dop853DenseOutput(s.t_old, s.t, s.y_old[k::count], s.F[:, k::count]) for s in segments]
        out.append(MotionPrediction.from_dense(dynamics, n, t0, t_end, DenseSolution(OdeSolution(ts, own))))
    return out


def prediction_from_estimate(dynamics, n, t, q_hill_from_body_, omega_body, t_end, covariance_body=None):
    """MotionPrediction from a published estimate: attitude in hill and body rate at t, and, if given, the
    6x6 error covariance of [dtheta_body, domega_body] (covariance_from_published); without it, none."""
    return MotionPrediction(dynamics, n, t, q_eci_from_body(t, n, q_hill_from_body_), omega_body, covariance_body,
                            t_end, with_covariance=covariance_body is not None)


def covariance_from_published(q_hill_from_body_, attitude_covariance_hill, rate_covariance_body):
    """The error covariance of [dtheta_body, domega_body] from the blocks an estimate publishes
    (estimation/target/odom: pose orientation covariance about hill axes, twist angular covariance in
    body axes; covariance_in_hill's dtheta_hill = C dtheta_body inverted). The attitude-rate
    cross-covariance is not published and is taken as zero."""
    c = quat_to_matrix(q_hill_from_body_)
    p = np.zeros((6, 6))
    p[:3, :3] = c.T @ np.asarray(attitude_covariance_hill, dtype=float) @ c
    p[3:, 3:] = np.asarray(rate_covariance_body, dtype=float)
    return 0.5 * (p + p.T)


# --------------------------------------------------------------------------------------------------
# Categories of target motion, seed 000 section 2.1 / Fig. 2


