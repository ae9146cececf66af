"""The captured target's mass properties from the combined body's response to known thruster firings: the
extended Kalman filter of seed 004 §2.2 on filterpy (no ROS).

Model, state and error state: ``mass_properties_model`` (the combined body of seed 004 §2.2; chaser_body axes,
vectors from the chaser's CoM, quaternions (x, y, z, w)). Observations (seed 004: omega, x_t'', q): the gyro rate
and the accelerometer's specific force at the chaser (``on_imu``, 6 values together), the star tracker's attitude
(``update``), and, optionally, the combined CoM's position (``on_position``; seed 004's GPS).

Time update: the nominal is integrated by RK4 in steps of at most ``max_step_s``, cut at every firing's start
and end (the known input, ``combined_body.Firing``); the transition Phi of the error over each step is the
central difference of that same step (44 perturbed copies integrated with the nominal as one batch); P = Phi P
Phi' + Qd is filterpy's ``ExtendedKalmanFilter.predict`` with F = Phi (the error state is zero between
updates). Qd: white noise of psd ``accel_psd_m2_s3`` on v_dot and ``angular_accel_psd_rad2_s3`` on omega_dot
(the model's integration and the unmodelled, e.g. the orbit's differential gravity; zero where the truth has
none, below), integrated into r and theta over the step (dt^3/3, dt^2/2 terms), and ``parameter_psd`` on the
parameters (default 0: constants).

The thrusters' execution errors make the known input uncertain, as white noise or as states (the firings' model in
``mass_properties_model``).

Measurement update: filterpy's ``ExtendedKalmanFilter.update`` (Joseph form) with H the central difference of
the measurement function (the IMU) or [.. I ..] (attitude, position), the innovation computed from the nominal
(attitude: ``filter_interface.attitude_innovation``), gated on the chi-square of its size; then the error is
folded into the nominal (both quaternions by Markley's reset, ``_fold``) and zeroed.

Iterated IMU update over a firing (``imu_iterations``): seed 004's gyro (1e-5 rad/s) against a full-thrust
pulse's response (~0.1 rad/s per IMU interval on the TugRobot) makes the response's curvature in a parameter
error of a few percent (~(3 %)^2 x 0.1 rad/s) several gyro sigmas, in the propagation, not in the measurement.
Over an interval in which a firing acts the update is Gauss-Newton on the error theta at the last update (prior
N(0, P0)) with the measurement z = h(f(x0 + theta)) + H w + v, f the propagation re-run from each iterate:
theta' = P0 Phi' H' S^-1 (z - h(f(x0 + theta)) + H Phi theta), to < 1 % of a sigma; the last linearization gives
the update, its prior mean -Phi theta from the re-propagated nominal (the one-step maximum a posteriori, test
``test_seed004_iterated_imu_update_over_a_firing_is_the_one_step_map_estimate``); it also takes the curvature of
F/(m + M) in M. Between firings the plain EKF update (the torque-free response's curvature is below a gyro sigma).

Re-linearization over the whole run (``relinearize``): the forward filter's covariance is the information of
every sample linearized where the estimate stood when the sample came, a few percent off at the first pulses;
the posterior after a full-thrust pulse from the prior is not Gaussian (the principal axes enter the inertia
times the moments' differences, the CoM squared, both uncertain), and what those early linearizations put into P
stays there. Worst where two true moments are equal (seed 004 §3.1's cylinder, (2, 1.5, 1.5)): the inertia
moves with the rotation dphi about the symmetry axis by (I2 - I3) dphi, zero in truth, but the prior's
I2 - I3 (a few percent) lends dphi information early that no data holds (docs/post_capture.md, "How these rules
were found"). ``relinearize`` is Gauss-Newton on the whole run, the maximum a
posteriori of the prior and every sample under seed 004 §2.2's model (its equations are unnumbered): carry the
current estimate back to the prior's time with the model without noise (``_propagate``), re-run the Kalman filter
on every finite, timely sample with Phi, H and the innovations from that one trajectory (the error state relative
to it, its prior mean the prior's, each sample gated on its own innovation, so that samples the forward filter
rejected while far off come back), take its end as the estimate; repeat until a step is below 1 % of every sigma
(two or three iterations from the default prior; test ``test_seed004_relinearize_is_the_batch_map_estimate``:
equal to scipy's least_squares on the same problem).
Its covariance is then the information along one trajectory near the truth, and at two equal moments dphi
about the symmetry axis keeps its prior (test
``test_seed004_relinearized_cylinder_learns_nothing_of_its_rotation_about_its_axis``).

The gyro's residual bias (``gyro_bias_covariance`` of the constructor): in a mission the gyro comes less an attitude
filter's bias estimate, whose error (~2e-6 rad/s on the TugRobot after 60 s, a fifth of a gyro sigma on every
sample, correlated over the run) the filter otherwise reads as dynamics; b is then a state after the thrusters'
errors (additive, its prior that estimate's covariance, walking as ``gyro_bias_walk_rad_s_sqrt_s``), the gyro
predicted as omega + b.

Process noise and consistency: ``accel_psd_m2_s3`` and ``angular_accel_psd_rad2_s3`` must be what the truth has.
A rate random walk the truth does not have makes P conservative where the information comes slowly: the split
of two equal moments (j2) is told by the gyroscopic drift the torque-free turn accumulates after the firings
(its sigma keeps falling to the window's end), which 1e-12 rad^2/s^3 masks.
"""

import dataclasses
import math

import numpy as np
from filterpy.kalman import ExtendedKalmanFilter
from scipy.stats import chi2

from flyby_estimation.filter_interface import FilterBase, attitude_innovation, new_counts
from flyby_estimation.mass_properties_model import (
    DIFFERENCE_STEPS,
    I_M,
    N_ERR,
    N_NOM,
    SL_J,
    SL_PHI,
    SL_R,
    SL_TH,
    SL_V,
    SL_W,
    SL_X,
    BatchBody,
    MassPropertyEstimate,
    central_offsets,
    cross_rows,
    difference,
    folded,
    imu_batch,
    j_from_moments,
    moments_from_j,
    perturb,
    rk4_batch,
    thruster_key,
)
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.combined_body import firing_breaks, inertia_from_principal, wrench_about_chaser
from flyby_sim.dynamics.rotation import quat_normalize, quat_to_matrix_many, skew


@dataclasses.dataclass(frozen=True)
class MassPropertyFilterConfig:
    """Parameters of MassPropertyFilter (validated; ValueError names the field).

    Attributes:
        chaser_mass_kg, chaser_inertia_body_kg_m2: the chaser's (seed 004's m, I_t0), known.
        accel_position_body_m: the accelerometer's position from the chaser CoM [m].
        gyro_sigma_rad_s, accel_sigma_mps2, attitude_sigma_rad, position_sigma_m: measurement noise, 1 sigma
            per axis (defaults: the chaser IMU's of chaser_body.ImuConfig; position 1 cm).
        accel_psd_m2_s3, angular_accel_psd_rad2_s3, parameter_psd: process noise (module doc).
        h_wheels_body_n_m_s: the wheels' momentum in body axes, held constant while the filter runs.
        max_step_s: longest propagation step [s].
        imu_iterations: most Gauss-Newton iterations of an IMU update over an interval with a firing, each
            re-propagating from the last update (module doc; 1: the plain EKF update).
        gate_probability: chi-square probability of the innovation gate (of the measurement's size).
        max_consecutive_outliers: rejections in a row after which a measurement is taken anyway (the model is
            then trusted less than the data: the gate must not lock the filter out).
        thrust_magnitude_sigma, thrust_misalignment_sigma_rad: each thruster's execution errors, 1 sigma (relative
            magnitude; misalignment [rad] about each axis normal to its force) (module doc).
        thrust_error_states: the execution errors as states, three per thruster (constant over the run, as the
            plant draws them), instead of white input noise (module doc).
        accel_interval_s: 0: the accelerometer reads the specific force at its stamp; > 0: as the plant's IMU
            (``flyby_sim.plant``) gives it over the interval T of this length ending at its stamp: the thrust's
            velocity increment over T (inertial) over T, resolved in the body axes at the stamp, the mean of
            omega_dot x p over T, and omega x (omega x p) at the stamp (``imu_batch``); the wrench held at the
            interval's middle, exact for firings that start and end on samples. Over a full-thrust firing on the
            TugRobot the body turns ~0.03 rad in an interval and its rate by ~0.04 rad/s: read at the stamp instead,
            the thrust's turn and the gyroscopic term's change are tens of accelerometer sigmas
            (docs/post_capture.md).
        exhaust_velocity_mps: the thrusters' Isp g0 [m/s]: the propellant the firings burn (|F| / v_e per second of
            each, known) leaves the combined body's mass in v_dot and the accelerometer's F/(m + M), as the plant
            burns it (its share of the CoM and inertia left out, as there); None: the mass is constant (seed 004
            §2.2's m). The chosen excitation burns 22 g of the TugRobot's 50 kg (4.4e-4 of F/(m + M), two of the
            mass's sigmas).
        gyro_bias_walk_rad_s_sqrt_s: the gyro bias's random walk, the bias state's process noise (the filter's
            gyro_bias_covariance; module doc).
    """

    chaser_mass_kg: float
    chaser_inertia_body_kg_m2: tuple
    accel_position_body_m: tuple = (0.0, 0.0, 0.0)
    gyro_sigma_rad_s: float = 1e-5
    accel_sigma_mps2: float = 1e-4
    attitude_sigma_rad: float = math.radians(0.01)
    position_sigma_m: float = 0.01
    accel_psd_m2_s3: float = 1e-10
    angular_accel_psd_rad2_s3: float = 1e-12
    parameter_psd: float = 0.0
    h_wheels_body_n_m_s: tuple = (0.0, 0.0, 0.0)
    max_step_s: float = 0.1
    imu_iterations: int = 3
    gate_probability: float = 0.9999
    max_consecutive_outliers: int = 20
    thrust_magnitude_sigma: float = 0.0
    thrust_misalignment_sigma_rad: float = 0.0
    thrust_error_states: bool = False
    accel_interval_s: float = 0.0
    exhaust_velocity_mps: float = None
    gyro_bias_walk_rad_s_sqrt_s: float = 0.0

    def __post_init__(self):
        require_positive('chaser_mass_kg', self.chaser_mass_kg)
        inertia = np.asarray(self.chaser_inertia_body_kg_m2, dtype=float)
        if inertia.shape != (3, 3) or not np.all(np.isfinite(inertia)) or np.linalg.eigvalsh(
                0.5 * (inertia + inertia.T)).min() <= 0.0:
            raise ValueError(f'chaser_inertia_body_kg_m2 must be a positive definite 3x3 [kg m^2], '
                             f'got {self.chaser_inertia_body_kg_m2!r}')
        for name in ('gyro_sigma_rad_s', 'accel_sigma_mps2', 'attitude_sigma_rad', 'position_sigma_m', 'max_step_s'):
            require_positive(name, getattr(self, name))
        if self.exhaust_velocity_mps is not None:
            require_positive('exhaust_velocity_mps', self.exhaust_velocity_mps)
        for name in ('accel_psd_m2_s3', 'angular_accel_psd_rad2_s3', 'parameter_psd', 'accel_interval_s',
                     'gyro_bias_walk_rad_s_sqrt_s', 'thrust_magnitude_sigma', 'thrust_misalignment_sigma_rad'):
            require_positive(name, getattr(self, name), allow_zero=True)
        if not 0.0 < self.gate_probability < 1.0:
            raise ValueError(f'gate_probability must be in (0, 1), got {self.gate_probability!r}')


class MassPropertyFilter(FilterBase):
    """Seed 004 §2.2's EKF of the combined body's state and the target's mass properties (module doc).

    ``update(t, q)`` fuses a star-tracker attitude (the ``filter_interface`` verb); ``on_imu(t, gyro, accel)``
    a gyro and accelerometer sample; ``on_position(t, r)`` a position. Known inputs: the firings given to the
    constructor or ``add_firings``, which must not start before the filter time (nor, with thrust_error_states,
    come from a thruster the constructor's firings did not name).
    """

    def __init__(self, config, prior, t0, r_m, v_mps, q_inertial_from_body, omega_body, state_sigmas,
                 firings=(), gyro_bias_covariance=None):
        """state_sigmas: 1 sigma per axis of (r [m], v [m/s], attitude [rad], omega [rad/s]) at t0 [s];
        gyro_bias_covariance: (3, 3) [rad^2/s^2] the prior of the gyro's residual bias b (gyro = omega + b + noise,
        a state after the thrusters' errors, walking as config.gyro_bias_walk_rad_s_sqrt_s; module doc), None: no
        bias."""
        super().__init__(config.gate_probability, config.max_consecutive_outliers)
        self.config = config
        self._gate_by_size = {n: float(chi2.ppf(config.gate_probability, df=n)) for n in (3, 6)}
        self.imu_counts = new_counts()
        self.position_counts = new_counts()
        self._m = float(config.chaser_mass_kg)
        self._i_t0 = np.asarray(config.chaser_inertia_body_kg_m2, dtype=float)
        self._p_acc = np.asarray(config.accel_position_body_m, dtype=float)
        self._h_w = np.asarray(config.h_wheels_body_n_m_s, dtype=float)
        self._firings = sorted(firings, key=lambda f: f.t_start_s)
        # thruster key -> index of its force-error state (thrust_error_states), in order of first firing
        self._thrusters = {}
        self._error_states = config.thrust_error_states and (config.thrust_magnitude_sigma > 0.0
                                                             or config.thrust_misalignment_sigma_rad > 0.0)
        if self._error_states:
            for f in self._firings:
                self._thrusters.setdefault(thruster_key(f), len(self._thrusters))
        n_thr = len(self._thrusters)
        n_bias = 0 if gyro_bias_covariance is None else 3
        self._sl_bias = slice(N_ERR + 3 * n_thr, N_ERR + 3 * n_thr + n_bias)  # in the error state
        self._n = N_ERR + 3 * n_thr + n_bias
        self._eps = np.concatenate((DIFFERENCE_STEPS, np.full(3 * n_thr + n_bias, 1e-6)))
        self._y = np.concatenate((r_m, v_mps, quat_normalize(q_inertial_from_body), omega_body,
                                  [prior.target_mass_kg], quat_normalize(prior.q_body_from_principal),
                                  prior.target_com_body_m, j_from_moments(prior.principal_moments_kg_m2),
                                  np.zeros(3 * n_thr + n_bias)))
        sig_r, sig_v, sig_att, sig_w = state_sigmas
        sigmas = np.concatenate(([sig_r] * 3, [sig_v] * 3, [sig_att] * 3, [sig_w] * 3, [prior.mass_sigma_kg],
                                 [prior.axes_sigma_rad] * 3, [prior.com_sigma_m] * 3, prior.j_sigma))
        p0 = np.zeros((self._n, self._n))
        p0[:N_ERR, :N_ERR] = np.diag(sigmas ** 2)
        for (_, u), i in self._thrusters.items():
            k = N_ERR + 3 * i
            p0[k:k + 3, k:k + 3] = self._force_error_covariance(np.array(u))
        if n_bias:
            p0[self._sl_bias, self._sl_bias] = gyro_bias_covariance
        self._kf = ExtendedKalmanFilter(dim_x=self._n, dim_z=6)
        self._kf.x = np.zeros((self._n, 1))
        self._kf.P = p0
        self._t = float(t0)
        self._consecutive_rejects = 0
        self._start = (self._t, self._y.copy(), p0.copy())  # the prior, for relinearize
        self._samples = []  # (t, kind, z) of every finite, timely measurement, in order, for relinearize

    def add_firings(self, firings):
        """More known inputs (combined_body.Firing); raises ValueError for one starting before the filter time or
        (thrust_error_states) from a thruster without an error state."""
        for f in firings:
            if f.t_start_s < self._t:
                raise ValueError(f'firing at t = {f.t_start_s} s starts before the filter time {self._t} s')
            if self._error_states and thruster_key(f) not in self._thrusters:
                raise ValueError(f'firing at t = {f.t_start_s} s is from a thruster the filter has no error state '
                                 f'for (position {f.position_body_m}): give every thruster in the constructor')
        self._firings = sorted(self._firings + list(firings), key=lambda f: f.t_start_s)

    @property
    def covariance(self):
        return self._kf.P.copy()

    def _force_error_covariance(self, force):
        """S_F = s_m^2 F F' + s_d^2 (|F|^2 U - F F'): a force's execution error (module doc)."""
        cfg = self.config
        ff = np.outer(force, force)
        return cfg.thrust_magnitude_sigma ** 2 * ff + cfg.thrust_misalignment_sigma_rad ** 2 * (
            float(force @ force) * np.eye(3) - ff)

    def _active(self, t):
        return [f for f in self._firings if f.t_start_s <= t < f.t_start_s + f.duration_s]

    def _burned_kg(self, t):
        """The propellant the firings have burned by t [kg]: |F| / v_e over each firing's time before t (0 without
        ``exhaust_velocity_mps``); a step's integration takes it at the step's middle."""
        v_e = self.config.exhaust_velocity_mps
        if v_e is None:
            return 0.0
        return sum(math.hypot(*f.force_body_n) * min(max(t - f.t_start_s, 0.0), f.duration_s)
                   for f in self._firings) / v_e

    def _wrench(self, y, t):
        """(force, moment about the chaser CoM) at t [s] of the firings for nominal states y (K, 24 + 3 n): the known
        wrench, plus (thrust_error_states) each firing thruster's error |F| e_i at its position, one per row."""
        force, moment = wrench_about_chaser(self._firings, t)
        if not self._thrusters:
            return force, moment
        force = np.repeat(force[None, :], y.shape[0], axis=0)
        moment = np.repeat(moment[None, :], y.shape[0], axis=0)
        for f in self._active(t):
            k = N_NOM + 3 * self._thrusters[thruster_key(f)]
            d_f = math.hypot(*f.force_body_n) * y[:, k:k + 3]
            force += d_f
            moment += cross_rows(np.asarray(f.position_body_m, dtype=float), d_f)
        return force, moment

    # --- time update -----------------------------------------------------------------------------------------

    def propagate_to(self, t):
        """Time update to t >= the filter time [s], cut at the firings' starts and ends (module doc)."""
        if t < self._t:
            raise ValueError(f'cannot propagate back from {self._t} s to {t} s')
        if t == self._t:
            return
        self._y, self._kf.F, self._kf.Q = self._transition(self._y, self._t, t)
        self._kf.predict()  # P = F P F' + Q (x stays zero)
        self._t = float(t)

    def _transition(self, y, t0, t1):
        """(the nominal at t1, Phi, Qd) from the nominal y at t0 [s]: RK4 steps of at most max_step_s cut at the
        firings' starts and ends, each step's Phi the central difference of that step, composed (module doc)."""
        n = self._n
        phi, q = np.eye(n), np.zeros((n, n))
        offsets = central_offsets(self._eps)
        t = t0
        for t_end in [b for b in firing_breaks(self._firings) if t0 < b < t1] + [t1]:
            while t < t_end:
                dt = min(self.config.max_step_s, t_end - t)
                if t_end - (t + dt) < 1e-9:
                    dt = t_end - t
                batch = perturb(y, offsets)
                out = rk4_batch(batch, dt, *self._wrench(batch, t), self._h_w, self._m, self._i_t0,
                                 self._burned_kg(t + 0.5 * dt))
                d = difference(out[1:], out[0])
                phi_step = ((d[:n] - d[n:]) / (2.0 * self._eps)[:, None]).T  # column i: d(error')/d(error_i)
                phi = phi_step @ phi
                q = phi_step @ q @ phi_step.T + self._process_noise(dt) + self._firing_noise(y, t, dt)
                y = out[0]
                t = t_end if dt == t_end - t else t + dt
        return y, phi, q

    def _firing_errors(self, y, t):
        """[(S_F (3, 3), X_f - c (3,), duration)] of the thruster firings active at t for the nominal y, when the
        execution errors are white input noise (module doc)."""
        cfg = self.config
        if self._error_states or (cfg.thrust_magnitude_sigma == 0.0 and cfg.thrust_misalignment_sigma_rad == 0.0):
            return []
        c = y[13] / (y[13] + self._m) * y[18:21]  # c = M/(M+m) X_s
        return [(self._force_error_covariance(np.asarray(f.force_body_n, dtype=float)),
                 np.asarray(f.position_body_m, dtype=float) - c, f.duration_s) for f in self._active(t)]

    def _firing_noise(self, y, t, dt):
        """Qd of the firings' force errors over a step of dt from t with the nominal y (module doc): dF held as white
        noise of psd S_F x the firing's duration on v_dot (inertial) and omega_dot, integrated into r and theta."""
        errors = self._firing_errors(y, t)
        q = np.zeros((self._n, self._n))
        if not errors:
            return q
        body = BatchBody(y[None, :], self._m, self._i_t0, self._burned_kg(t + 0.5 * dt))
        c_inertial_from_body = quat_to_matrix_many(y[None, 6:10])[0]
        rates = np.zeros((6, 6))
        for s_f, lever, duration in errors:
            g = np.vstack((c_inertial_from_body / body.mass[0], body.inertia_inv[0] @ skew(lever)))
            rates += g @ s_f @ g.T * duration
        pos, rate = np.r_[0:3, 6:9], np.r_[3:6, 9:12]
        q[np.ix_(rate, rate)] = rates * dt
        q[np.ix_(pos, pos)] = rates * dt ** 3 / 3.0
        q[np.ix_(pos, rate)] = q[np.ix_(rate, pos)] = rates * dt ** 2 / 2.0
        return q

    def _process_noise(self, dt):
        q = np.zeros((self._n, self._n))
        for sl_pos, sl_rate, psd in ((SL_R, SL_V, self.config.accel_psd_m2_s3),
                                     (SL_TH, SL_W, self.config.angular_accel_psd_rad2_s3)):
            q[sl_pos, sl_pos] = np.eye(3) * psd * dt ** 3 / 3.0
            q[sl_pos, sl_rate] = q[sl_rate, sl_pos] = np.eye(3) * psd * dt ** 2 / 2.0
            q[sl_rate, sl_rate] = np.eye(3) * psd * dt
        q[12:N_ERR, 12:N_ERR] += np.eye(N_ERR - 12) * self.config.parameter_psd * dt
        bias = np.arange(self._sl_bias.start, self._sl_bias.stop)  # empty without the gyro bias state
        q[bias, bias] += self.config.gyro_bias_walk_rad_s_sqrt_s ** 2 * dt
        return q

    # --- measurement updates ---------------------------------------------------------------------------------

    def on_imu(self, t, gyro_rad_s, accel_mps2):
        """Fuse a gyro rate and an accelerometer specific force (body axes) stamped t; an UpdateResult.

        Over an interval with a firing the update is iterated (module doc): Gauss-Newton on the error theta at the
        last update's time t0 under its prior N(0, P0), the measurement z = h(f(x0 + theta)) + H w + v with f the
        propagation to t re-run from each iterate, so the curvature of both the response to the firing and the
        accelerometer's F/(m + M) in the parameters is seen; the last linearization gives the update."""
        z, rejected = self._finite_measurement(t, np.concatenate((np.ravel(gyro_rad_s), np.ravel(accel_mps2))), 6,
                                               'imu sample', self.imu_counts)
        if rejected is not None:
            return rejected
        stale = self._stale_measurement(t, self._t, 'imu sample', self.imu_counts)
        if stale is not None:
            return stale
        self._samples.append((float(t), 'imu', z))
        t0, y0, p0 = self._t, self._y, self._kf.P
        t_wrench = t - 0.5 * self.config.accel_interval_s
        r = self._imu_noise(y0, t_wrench)
        curved = any(f.t_start_s < t and f.t_start_s + f.duration_s > min(t0, t_wrench) for f in self._firings)
        iterations = self.config.imu_iterations if curved else 1
        sigma0 = np.sqrt(np.diag(p0))
        sigma0 = np.where(sigma0 > 0.0, sigma0, np.inf)
        theta = np.zeros(self._n)
        for iteration in range(iterations):
            y1, phi, q = self._transition(perturb(y0, theta[None, :])[0], t0, t)
            h, jac = self._imu_and_jacobian(y1, t_wrench)
            m = -phi @ theta  # the prior's mean at t, from the nominal y1 = f(x0 + theta)
            p_pred = phi @ p0 @ phi.T + q
            residual = z - h - jac @ m
            if iteration + 1 == iterations:
                break
            # theta' = P0 Phi' H' S^-1 (z - h(f(x0 + theta)) + H Phi theta)
            theta_next = p0 @ phi.T @ jac.T @ np.linalg.solve(jac @ p_pred @ jac.T + r, residual)
            if np.max(np.abs(theta_next - theta) / sigma0) < 1e-2:  # the iterate moved by < 1 % of a sigma
                break
            theta = theta_next
        self._y, self._t = y1, float(t)
        self._kf.P = p_pred
        self._kf.x = m[:, None]
        return self._fuse(t, residual, jac, r, self.imu_counts, z - h)

    def _imu_noise(self, y, t_wrench):
        """The IMU's R (6, 6) for the nominal y: the gyro's and accelerometer's noise, plus (white-noise execution
        errors) the firings' force errors the accelerometer reads directly (module doc)."""
        r = np.diag([self.config.gyro_sigma_rad_s ** 2] * 3 + [self.config.accel_sigma_mps2 ** 2] * 3)
        errors = self._firing_errors(y, t_wrench)
        if errors:
            body = BatchBody(y[None, :], self._m, self._i_t0, self._burned_kg(t_wrench))
            p_acc = self._p_acc - body.c[0]
            for s_f, lever, _ in errors:
                h_f = np.eye(3) / body.mass[0] - skew(p_acc) @ body.inertia_inv[0] @ skew(lever)
                r[3:, 3:] += h_f @ s_f @ h_f.T
        return r

    def _imu_and_jacobian(self, y, t_wrench):
        """The IMU predicted at the nominal y (24 + 3 n,) with the wrench at t_wrench, and its Jacobian in the error
        state there."""
        n = self._n
        batch = perturb(y, central_offsets(self._eps))
        h = imu_batch(batch, *self._wrench(batch, t_wrench), self._h_w, self._m, self._i_t0,
                       self._burned_kg(t_wrench), self._p_acc, self.config.accel_interval_s)
        if self._sl_bias.stop > self._sl_bias.start:  # the gyro's bias state
            h[:, :3] += batch[:, N_NOM + self._sl_bias.start - N_ERR:N_NOM + self._sl_bias.stop - N_ERR]
        return h[0], ((h[1:n + 1] - h[n + 1:]) / (2.0 * self._eps)[:, None]).T

    def update(self, t, z):
        """Fuse a star-tracker attitude q_inertial_from_body (x, y, z, w) stamped t; an UpdateResult."""
        q, rejected = self._unit_quaternion_measurement(t, z, 1e-3, 'attitude')
        if rejected is not None:
            return rejected
        stale = self._stale_measurement(t, self._t, 'attitude')
        if stale is not None:
            return stale
        self._samples.append((float(t), 'attitude', q))
        self.propagate_to(t)
        innovation, jac, r = self._linearized('attitude', self._y, t, q)
        return self._fuse(t, innovation, jac, r, self.counts, innovation)

    def on_position(self, t, r_m):
        """Fuse a position of the combined CoM (inertial) stamped t; an UpdateResult."""
        z, rejected = self._finite_measurement(t, r_m, 3, 'position', self.position_counts)
        if rejected is not None:
            return rejected
        stale = self._stale_measurement(t, self._t, 'position', self.position_counts)
        if stale is not None:
            return stale
        self._samples.append((float(t), 'position', z))
        self.propagate_to(t)
        innovation, jac, r = self._linearized('position', self._y, t, z)
        return self._fuse(t, innovation, jac, r, self.position_counts, innovation)

    def _linearized(self, kind, y, t, z):
        """(z - h(y), H, R) of a measurement of kind 'imu', 'attitude' or 'position' stamped t at the nominal y."""
        if kind == 'imu':
            t_wrench = t - 0.5 * self.config.accel_interval_s
            h, jac = self._imu_and_jacobian(y, t_wrench)
            return z - h, jac, self._imu_noise(y, t_wrench)
        jac = np.zeros((3, self._n))
        if kind == 'attitude':
            jac[:, SL_TH] = np.eye(3)
            return attitude_innovation(y[6:10], z), jac, np.eye(3) * self.config.attitude_sigma_rad ** 2
        jac[:, SL_R] = np.eye(3)
        return z - y[0:3], jac, np.eye(3) * self.config.position_sigma_m ** 2

    def _fuse(self, t, innovation, jac, r, counts, z):
        """Gate on the innovation's NIS, then filterpy's update of the error (prior mean kf.x, measurement z from
        the nominal, so that z - H x is the innovation) and the fold; a rejected sample folds the prior mean."""
        kf = self._kf
        s = jac @ kf.P @ jac.T + r
        nis = float(innovation @ np.linalg.solve(s, innovation))
        gate = self._gate_by_size[innovation.size]
        if self._gated(nis, innovation.size, self._consecutive_rejects):
            self._consecutive_rejects += 1
            self._fold(kf.x[:, 0])
            return self._outcome('outlier', t, nis, f'normalized innovation squared {nis:.4g} above the gate '
                                                     f'{gate:.4g}', innovation, counts)
        self._consecutive_rejects = 0
        kf.update(z[:, None], HJacobian=lambda _x: jac, Hx=lambda x: jac @ x, R=r)  # Joseph form
        self._fold(kf.x[:, 0])
        return self._outcome('accepted', t, nis, '', innovation, counts)

    def _gated(self, nis, size, consecutive_rejects):
        """Whether a measurement of size with this NIS is rejected: above the gate, unless it would make
        max_consecutive_outliers in a row."""
        return nis > self._gate_by_size[size] and consecutive_rejects + 1 < self.config.max_consecutive_outliers

    def _fold(self, dx):
        """The update's error folded into the nominal, both quaternions with Markley's reset, P <- G P G'."""
        self._y, self._kf.P = folded(self._y, self._kf.P, dx)
        self._kf.x = np.zeros((self._n, 1))

    # --- re-linearization over the whole run -------------------------------------------------------------------

    def relinearize(self, max_iterations=6, tolerance=0.01):
        """Gauss-Newton on the whole run (module doc): each iteration carries the current estimate back to the
        prior's time (the model without noise), re-runs the Kalman filter on every sample linearized along that one
        trajectory (``_batch_pass``), and takes its end as the estimate; until an iteration moves no error component
        by tolerance of its sigma, at most max_iterations (>= 1). Returns the iterations taken."""
        if max_iterations < 1:
            raise ValueError(f'max_iterations must be >= 1, got {max_iterations!r}')
        y, iterations = self._y, 0
        while iterations < max_iterations:
            y_next, p = self._batch_pass(y)
            step = difference(y_next[None, :], y)[0] / np.sqrt(np.diag(p))
            y, iterations = y_next, iterations + 1
            if np.max(np.abs(step)) < tolerance:
                break
        self._y, self._kf.P = y, p
        return iterations

    def _batch_pass(self, y):
        """(the estimate, its covariance) at the filter time of the Kalman filter on every sample since the prior,
        linearized along the noise-free trajectory through y: the error state relative to it, its prior mean the
        prior's, each sample gated on its own innovation as the forward filter gates (``_gated``)."""
        t0, y_prior, p = self._start
        ref = self._propagate(y, self._t, t0)
        dx = difference(y_prior[None, :], ref)[0]
        t, rejects = t0, 0
        for t_k, kind, z in self._samples + [(self._t, None, None)]:
            if t_k > t:
                ref, phi, q = self._transition(ref, t, t_k)
                dx, p, t = phi @ dx, phi @ p @ phi.T + q, t_k
            if kind is None:
                break
            innovation, jac, r = self._linearized(kind, ref, t_k, z)
            innovation = innovation - jac @ dx
            s = jac @ p @ jac.T + r
            if self._gated(float(innovation @ np.linalg.solve(s, innovation)), innovation.size, rejects):
                rejects += 1
                continue
            rejects = 0
            gain = p @ jac.T @ np.linalg.inv(s)
            dx = dx + gain @ innovation
            i_kh = np.eye(self._n) - gain @ jac
            p = i_kh @ p @ i_kh.T + gain @ r @ gain.T  # Joseph form
        return folded(ref, p, dx)

    # --- outputs ---------------------------------------------------------------------------------------------

    def predict(self, t):
        """The nominal (24 + 3 n,) carried to t >= the filter time without changing the filter (r, v, q, omega, M,
        Q, X_s, j, the thrusters' errors)."""
        if t < self._t:
            raise ValueError(f'cannot predict back from {self._t} s to {t} s')
        return self._propagate(self._y, self._t, t)

    def _propagate(self, y, t_from, t_to):
        """The nominal y (24 + 3 n,) carried from t_from to t_to [s], forward or back, by the model without noise:
        RK4 steps of at most max_step_s cut at the firings' starts and ends, each under the wrench over it."""
        sign = 1.0 if t_to >= t_from else -1.0
        lo, hi = min(t_from, t_to), max(t_from, t_to)
        cuts = [b for b in firing_breaks(self._firings) if lo < b < hi]
        y, t = y[None, :].copy(), t_from
        for t_end in (cuts if sign > 0.0 else cuts[::-1]) + [t_to]:
            while sign * (t_end - t) > 0.0:
                dt = min(self.config.max_step_s, sign * (t_end - t))
                t_next = t_end if sign * (t_end - t) - dt < 1e-9 else t + sign * dt
                y = rk4_batch(y, t_next - t, *self._wrench(y, min(t, t_next)), self._h_w, self._m, self._i_t0,
                               self._burned_kg(0.5 * (t + t_next)))
                t = t_next
        return y[0]

    def state(self):
        """The MassPropertyEstimate at the filter time."""
        y, p = self._y, self._kf.P
        sig = np.sqrt(np.diag(p))
        # Principal moments' sigma through the map's Jacobian (central differences in j).
        j = y[21:24]
        jac = np.empty((3, 3))
        for k in range(3):
            dj = np.zeros(3)
            dj[k] = 1e-6
            jac[:, k] = (moments_from_j(j + dj) - moments_from_j(j - dj)) / 2e-6
        moments_cov = jac @ p[SL_J, SL_J] @ jac.T
        moments = moments_from_j(j)
        return MassPropertyEstimate(
            self._t, float(y[13]), y[18:21].copy(), quat_normalize(y[14:18]), moments,
            inertia_from_principal(moments, y[14:18]), float(sig[I_M]), sig[SL_X].copy(), sig[SL_PHI].copy(),
            np.sqrt(np.diag(moments_cov)), y[0:3].copy(), y[3:6].copy(), y[6:10].copy(), y[10:13].copy(), p.copy(),
            y[N_NOM:N_NOM + self._sl_bias.start - N_ERR].reshape(-1, 3).copy())


