"""What the estimator does after the capture (issue 16, DESIGN §10; no ROS): the prior of the target's mass
properties from the estimates at the capture, and seed 004 §2.2's filter (``mass_properties.MassPropertyFilter``)
over the excitation, on the chaser's IMU.

Frames: chaser_body axes, vectors from the chaser's CoM, quaternions (x, y, z, w) as ``mass_properties``.

The prior (``mass_property_prior``):

* the target's CoM X_s: where the navigation filter had the chaser at the capture, relative to the target's CoM,
  in the chaser's axes of the attitude filter then;
* its principal axes Q: the target attitude filter's estimate at the capture, relative to the chaser's, times the
  principal axes of ``target.inertia_kg_m2`` in target_body; their sigma that estimate's own (the largest of its
  attitude covariance) unless the scenario gives one;
* both moved as the arm's compliance moved the grasp handle from the first contact to the lock (the simulator's
  ``grasp_damped``: the arm's joint encoders), a displacement d and a rotation R(e) in the chaser's axes:
  X_s' = X_s + d + (U - R(e)) C r_g, C' = R(e) C (C the target's attitude in the chaser's, r_g the grasp point);
* its mass and principal moments: ``target.mass_kg`` and the moments of ``target.inertia_kg_m2`` each drawn with
  the relative 1-sigma of the scenario's post_capture.mass_estimation from a stream of the scenario's seed (a
  catalogue value and its uncertainty; the plant's truth is the scenario's own values).

The run (``MassEstimationRun``): guidance announces the excitation's start t_x (its ``damping_complete`` event); the
filter starts at the IMU sample stamped t_x from the attitude filter's estimate there, with the firings guidance
commands from t_x (``mass_properties_excitation.thruster_firings``: each firing as the plant allocates it on the
thrusters) and the wheels' momentum guidance accounts for (held: nothing commands the wheels during the
excitation); it takes every later sample: the gyro less the attitude filter's bias estimate at t_x (held: that
estimate's error is the filter's gyro bias state, its prior the attitude filter's bias covariance there), the
accelerometer's mean over the sample interval (``MassPropertyFilterConfig.accel_interval_s``) and the star tracker;
the thrusters' execution errors of the scenario (unknown to the filter in each run) are its input's uncertainty,
the propellant they burn leaves the mass (``exhaust_velocity_mps``). Its process noise is none: the plant's combined
body feels no force or torque but the firings' (no environmental torque), and the orbit's differential gravity at
the accelerometer, at most 3 n^2 |p|, is 7e-7 m/s^2 on the TugRobot (p 0.2 m) and 1e-5 m/s^2 on paper_flyby_tug's
body (3 m): a hundredth and a tenth of the accelerometer's sigma. Samples that
come before the announcement (the topics race) wait in a buffer of the samples after the capture. An estimate is
given every ``PUBLISH_EVERY`` samples and the final one window_s after t_x, relinearized
(``MassPropertyFilter.relinearize``: the batch maximum a posteriori of the window, consistent where the forward
filter's covariance keeps its early linearizations, docs/post_capture.md).
"""

import collections
import dataclasses
import math
from typing import NamedTuple

import numpy as np

from flyby_estimation.mass_properties import (
    MassPropertyFilter,
    MassPropertyFilterConfig,
    MassPropertyPrior,
    j_from_moments,
)
from flyby_estimation.mass_properties_excitation import excitation_firings, thruster_firings
from flyby_estimation.relative_nav import RelativeNavFilter, relative_nav_config_from_scenario
from flyby_msgs_py.stamped import StampedBuffer
from flyby_msgs_py.wire import STAMP_TOLERANCE_S
from flyby_sim.dynamics.attitude import body_point_state
from flyby_sim.dynamics.orbital import (
    cw_transition_matrix,
    q_eci_from_body,
    relative_accel_components,
    rk4_step_floats,
)
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_matrix,
    quat_from_rotation_vector,
    quat_multiply,
    quat_rotate,
    quat_to_matrix,
    skew,
)

PUBLISH_EVERY = 10  # IMU samples between two published estimates (1 s at 10 Hz)
SAMPLES_KEPT = 600  # IMU samples after the capture kept for a late announcement of the excitation
# The filter's start: position and velocity are not observed (no position sensor after the capture); the rate's
# sigma covers the gyro's noise and bias error.
_STATE_SIGMAS = (1.0, 0.1)  # r [m], v [m/s]
_RATE_SIGMA_RAD_S = 1e-4
# The combined CoM refined by the transport's coasts (``ComCoast``) is given at the stamps on this grid after the final
# estimate (``on_com_grid``; guidance waits for it there), from a coast with nothing firing this long at least.
COM_PERIOD_S = 50.0
COM_COAST_MIN_S = 200.0
_PRIOR_STREAM = 16  # the prior's random stream: numpy default_rng([seed, 16])
_ATTACHMENT_STREAM = 17  # a start attached: the attachment's errors, default_rng([seed, 17])


class CaptureSnapshot(NamedTuple):
    """The estimates stamped at the capture (the last at or before it): the chaser's position relative to the
    target's CoM in hill [m] and attitude, the target's attitude (q_hill_from_body each) and its covariance [rad^2,
    about hill axes]; the target's CoM in hill [m] (the origin at a capture)."""

    t: float
    r_chaser_hill: np.ndarray
    q_hill_from_chaser: np.ndarray
    q_hill_from_target: np.ndarray
    target_attitude_covariance_hill: np.ndarray
    r_target_hill: tuple = (0.0, 0.0, 0.0)

    @property
    def r_chaser_body(self):
        """The chaser's position relative to the target's CoM in its own axes [m] (-X_s)."""
        return quat_rotate(quat_conjugate(self.q_hill_from_chaser), self.r_chaser_hill)


def attachment_snapshot(scenario):
    """The CaptureSnapshot of a run that starts attached (scenario post_capture.start attached, seed 004 §3.1): the
    attachment of post_capture.attachment as the crew or the docking fixture knows it, its CoM X_s and the target's
    axes each drawn with the prior's sigma (prior_com_sigma_m, prior_axes_sigma_deg) from a stream of the seed, at
    the chaser's initial position and attitude."""
    cfg = scenario.post_capture.mass_estimation
    rng = np.random.default_rng([scenario.seed, _ATTACHMENT_STREAM])
    z = rng.standard_normal(6)
    x_s = np.asarray(scenario.post_capture.attachment.target_com_chaser_body_m, dtype=float)
    x_s = x_s + cfg.prior_com_sigma_m * z[:3]
    sigma_rad = math.radians(cfg.prior_axes_sigma_deg)
    q_chaser = scenario.q_hill_from_chaser_body0
    q_chaser_from_target = quat_multiply(scenario.q_chaser_from_target_attached,
                                         quat_from_rotation_vector(sigma_rad * z[3:]))
    r_chaser_hill = -quat_rotate(q_chaser, x_s)
    return CaptureSnapshot(0.0, r_chaser_hill, q_chaser, quat_multiply(q_chaser, q_chaser_from_target),
                           sigma_rad ** 2 * np.eye(3),
                           tuple(np.asarray(scenario.chaser.initial_position_hill_m, dtype=float) - r_chaser_hill))


def principal_axes(inertia_kg_m2):
    """(principal moments (3,) ascending [kg m^2], q_body_from_principal (x, y, z, w)) of an inertia matrix, the
    axes a right-handed frame."""
    moments, axes = np.linalg.eigh(0.5 * (np.asarray(inertia_kg_m2, dtype=float) + np.asarray(inertia_kg_m2).T))
    if np.linalg.det(axes) < 0.0:
        axes[:, 2] = -axes[:, 2]
    return moments, quat_from_matrix(axes)


def mass_property_prior(scenario, snapshot, arm_displacement_body_m=(0.0, 0.0, 0.0),
                        arm_rotation_body_rad=(0.0, 0.0, 0.0)):
    """The MassPropertyPrior of the target at the lock: the capture's estimates moved by the arm's deflection
    (module doc)."""
    cfg = scenario.post_capture.mass_estimation
    rng = np.random.default_rng([scenario.seed, _PRIOR_STREAM])
    moments, q_target_from_principal = principal_axes(scenario.target_inertia)
    z = rng.standard_normal(4)
    mass_kg = scenario.target.mass_kg * (1.0 + cfg.prior_mass_sigma * z[0])
    moments_prior = moments * (1.0 + cfg.prior_moments_sigma * z[1:])
    # The moments' relative sigma in the filter's j (a diagonal P0: the map's Jacobian, its cross terms left out).
    jac = np.empty((3, 3))
    for k in range(3):
        d = np.zeros(3)
        d[k] = 1e-6 * moments_prior[k]
        jac[:, k] = (j_from_moments(moments_prior + d) - j_from_moments(moments_prior - d)) / (2.0 * d[k])
    j_cov = jac @ np.diag((cfg.prior_moments_sigma * moments_prior) ** 2) @ jac.T
    q_capture = quat_multiply(quat_conjugate(snapshot.q_hill_from_chaser), snapshot.q_hill_from_target)
    rotation = quat_from_rotation_vector(arm_rotation_body_rad)
    q_chaser_from_target = quat_multiply(rotation, q_capture)
    handle = quat_rotate(q_capture, scenario.target.grasp_point_body_m)
    x_s = (-snapshot.r_chaser_body + np.asarray(arm_displacement_body_m, dtype=float) + handle
           - quat_rotate(rotation, handle))
    axes_sigma_rad = (math.sqrt(float(np.linalg.eigvalsh(snapshot.target_attitude_covariance_hill)[-1]))
                      if cfg.prior_axes_sigma_deg is None else math.radians(cfg.prior_axes_sigma_deg))
    return MassPropertyPrior(float(mass_kg), tuple(x_s),
                             tuple(quat_multiply(q_chaser_from_target, q_target_from_principal)),
                             tuple(moments_prior), cfg.prior_mass_sigma * scenario.target.mass_kg,
                             cfg.prior_com_sigma_m, axes_sigma_rad, tuple(np.sqrt(np.diag(j_cov))))


class ImuSample(NamedTuple):
    """One chaser IMU sample after the capture as the filter takes it: stamp [s], the attitude filter's attitude
    (q_eci_from_body) and bias-corrected rate [rad/s] there, the accelerometer [m/s^2] and the star tracker's
    attitude in ECI (or None); the attitude filter's gyro bias estimate [rad/s] and its covariance [rad^2/s^2]
    (None: not known)."""

    t: float
    q_eci_from_body: np.ndarray
    omega_body: np.ndarray
    accel_body_mps2: np.ndarray
    q_star_eci: np.ndarray
    gyro_bias_rad_s: np.ndarray = np.zeros(3)
    gyro_bias_covariance: np.ndarray = None


def imu_sample(t, estimate, specific_force_body, q_star_hill, n):
    """The ImuSample of an IMU sample at t from the attitude filter's estimate (``ChaserAttitudeEstimate``) there."""
    return ImuSample(t, estimate.q_eci_from_body, estimate.omega_body, np.asarray(specific_force_body, dtype=float),
                     None if q_star_hill is None else q_eci_from_body(t, n, np.asarray(q_star_hill, dtype=float)),
                     estimate.bias_rad_s, estimate.covariance[3:6, 3:6])


@dataclasses.dataclass(frozen=True)
class TargetInertiaEstimate:
    """estimation/target/inertia (DESIGN §10): the target's mass [kg], CoM from the chaser's CoM [m] and inertia
    about it [kg m^2], chaser_body axes, stamped t; with the filter's whole estimate (its sigmas) and whether it is
    the final one."""

    t: float
    mass_kg: float
    com_body_m: np.ndarray
    inertia_body_kg_m2: np.ndarray
    estimate: object  # mass_properties.MassPropertyEstimate
    final: bool


class MassEstimationRun:
    """The filter over the excitation (module doc). ``start`` once the excitation's start is known, ``on_sample``
    at every IMU sample after the capture; both return TargetInertiaEstimates."""

    def __init__(self, scenario, chaser_mass_kg):
        self.scenario = scenario
        self.prior = None
        self.chaser_mass_kg = chaser_mass_kg
        self.period_s = 1.0 / scenario.sensors.chaser_imu.rate_hz
        self.window_s = scenario.post_capture.mass_estimation.window_s
        self.samples = collections.deque(maxlen=SAMPLES_KEPT)  # waiting for the start
        self.filter = None
        self.t_start = None
        self.count = 0
        self.done = False
        self.gyro_bias0 = None  # the attitude filter's gyro bias estimate at the start [rad/s]

    def start(self, t_start, h_wheels_body_n_m_s, prior):
        """The excitation starts at t_start [s] with the wheels holding h_wheels_body_n_m_s [N m s, chaser_body];
        prior: the MassPropertyPrior at the lock."""
        self.t_start = t_start
        self.prior = prior
        self.h_wheels = tuple(float(h) for h in h_wheels_body_n_m_s)
        waiting, self.samples = list(self.samples), None
        out = []
        for sample in waiting:
            out += self.on_sample(sample)
        return out

    def on_sample(self, s):
        if self.done:
            return []
        if self.t_start is None:
            self.samples.append(s)
            return []
        if s.t < self.t_start - STAMP_TOLERANCE_S:
            return []
        if self.filter is None:
            self.gyro_bias0 = s.gyro_bias_rad_s
            self.filter = self._new_filter(s)
            return []
        f = self.filter
        # the gyro less the attitude filter's bias estimate at the start, held (the filter's bias state, module doc)
        f.on_imu(s.t, s.omega_body + s.gyro_bias_rad_s - self.gyro_bias0, s.accel_body_mps2)
        if s.q_star_eci is not None:
            f.update(s.t, s.q_star_eci)
        self.count += 1
        final = s.t >= self.t_start + self.window_s - STAMP_TOLERANCE_S
        if not (final or self.count % PUBLISH_EVERY == 0):
            return []
        self.done = final
        if final:  # the batch maximum a posteriori of the whole window (module doc)
            f.relinearize()
        e = f.state()
        return [TargetInertiaEstimate(s.t, e.target_mass_kg, e.target_com_body_m, e.target_inertia_body_kg_m2, e,
                                      final)]

    def _new_filter(self, s):
        """The filter at the first sample of the excitation (its attitude and rate from the attitude filter there)."""
        sc = self.scenario
        imu = sc.sensors.chaser_imu
        config = MassPropertyFilterConfig(
            self.chaser_mass_kg, tuple(map(tuple, sc.chaser_inertia.tolist())),
            gyro_sigma_rad_s=imu.gyro_noise_sigma_rad_s, accel_sigma_mps2=imu.accel_noise_sigma_mps2,
            attitude_sigma_rad=math.radians(imu.star_tracker_sigma_deg), h_wheels_body_n_m_s=self.h_wheels,
            max_step_s=self.period_s, accel_interval_s=self.period_s,
            thrust_magnitude_sigma=sc.chaser.thrusters.magnitude_error_sigma,
            thrust_misalignment_sigma_rad=math.radians(sc.chaser.thrusters.direction_error_sigma_deg),
            thrust_error_states=True,  # the plant draws them once per run: constant, estimated
            exhaust_velocity_mps=sc.thruster_layout.exhaust_velocity_mps,
            gyro_bias_walk_rad_s_sqrt_s=imu.gyro_bias_walk_rad_s_sqrt_s,
            accel_psd_m2_s3=0.0, angular_accel_psd_rad2_s3=0.0)  # what the combined body has (module doc)
        firings = thruster_firings(sc.thruster_layout,
                                   excitation_firings(sc.post_capture.mass_estimation.excitation, self.t_start),
                                   self.period_s)
        attitude_sigma = max(math.radians(imu.star_tracker_sigma_deg), 1e-6)
        return MassPropertyFilter(config, self.prior, s.t, np.zeros(3), np.zeros(3), s.q_eci_from_body, s.omega_body,
                                  (*_STATE_SIGMAS, attitude_sigma, _RATE_SIGMA_RAD_S), firings,
                                  s.gyro_bias_covariance)


def combined_com_covariance(chaser_mass_kg, estimate):
    """The covariance [m^2] of the combined CoM from the chaser's, c = M X_s / (m + M) (seed 004 §2.2,
    ``combined_body.combined_mass_properties``), from a ``mass_properties.MassPropertyEstimate``'s 1-sigma of the
    target's mass M and CoM X_s (to first order)."""
    m, big_m = float(chaser_mass_kg), float(estimate.target_mass_kg)
    total = m + big_m
    x_s = np.asarray(estimate.target_com_body_m, dtype=float)
    dc_dm = m / total**2 * x_s
    return ((big_m / total) ** 2 * np.diag(np.asarray(estimate.com_sigma_m, dtype=float) ** 2)
            + estimate.mass_sigma_kg**2 * np.outer(dc_dm, dc_dm))


def on_com_grid(t, t_start):
    """True for a stamp t [s] of COM_PERIOD_S's grid after t_start, the final mass-property estimate's."""
    return t > t_start + STAMP_TOLERANCE_S and abs(t - round(t / COM_PERIOD_S) * COM_PERIOD_S) <= STAMP_TOLERANCE_S


def _scaled_inverse(a):
    """The inverse of a symmetric positive definite matrix of mixed units, scaled to a unit diagonal first."""
    scale = 1.0 / np.sqrt(np.diag(a))
    return scale[:, None] * np.linalg.inv(scale[:, None] * a * scale[None, :]) * scale[None, :]


class ComCoast:
    """The combined CoM from the chaser's, refined over a coast with nothing firing (issue 17, docs/transport.md).

    The least squares, with the prior of p, of the relative positions of the chaser's CoM over the coast,
    y_k = r(t_k) + C_k p + noise: r the combined CoM's position, coasted from its state at the coast's start x0 (a
    reference coasted by the plant's relative dynamics, seed 000 eq 1 or eq 22, and the deviation from it by CW's
    transition matrix, seed 000 eq 22), C_k the attitude estimate (hill from chaser_body), p the chaser's CoM from
    the combined one [m, chaser_body]. Unknowns: x0's deviation and p's, with the navigation filter's knowledge as
    their prior: its state at the coast's start, which it has for p's prior mean, is off by -J dp (J the derivative
    of the body point's state by p, seed 000 eq 8-9) and by its own covariance; so the knowledge it carried across a
    firing (a known input) is kept (a weak prior without it).

    Why it sees p: a body held at rest inertially turns in hill at the orbit's rate, so C_k p traces a circle, and
    no CW coast does (CW's in-plane ellipse is twice as long along-track as it is radially, and its out-of-plane
    motion has no constant): over a good part of an orbit the positions fix p to a fraction of a millimetre, where
    the navigation filter, which takes p as known, would carry its error as a velocity n x C dp (seed 1 of
    paper_flyby_transport: 3-9 mm, 0.007-0.015 N s on 1600 kg)."""

    X0_PRIOR_SIGMAS = (1.0, 0.1)  # the weak prior of x0's deviation: r [m], v [m/s]

    def __init__(self, t, x0, p_prior_m, p_covariance_m2, n, radius_m, dynamics, sigma_m, x0_covariance=None,
                 sensitivity=None):
        """x0: the combined CoM's state at t (hill, [m, m/s]) and its 6x6 covariance given p (None: the weak prior);
        sensitivity: J (6x3), the derivative of the chaser's CoM state in hill by p."""
        self.t0 = self.t = float(t)
        self.x_ref = [float(v) for v in x0]
        self.p_prior = np.asarray(p_prior_m, dtype=float)
        self.n, self.accel = n, relative_accel_components(dynamics, n, radius_m)
        self.weight = 1.0 / sigma_m**2
        p_cov = np.asarray(p_covariance_m2, dtype=float)
        cov = np.zeros((9, 9))
        if x0_covariance is None:
            sr, sv = self.X0_PRIOR_SIGMAS
            cov[:6, :6] = np.diag([sr**2] * 3 + [sv**2] * 3)
        else:
            j = np.asarray(sensitivity, dtype=float)
            cov[:6, :6] = np.asarray(x0_covariance, dtype=float) + j @ p_cov @ j.T
            cov[:6, 6:] = -j @ p_cov
            cov[6:, :6] = cov[:6, 6:].T
        cov[6:, 6:] = p_cov
        self.info = _scaled_inverse(cov)
        self.b = np.zeros(9)

    @property
    def duration_s(self):
        return self.t - self.t0

    def _rhs(self, _t, y):
        return [*y[3:], *self.accel(y[:3], y[3:], (0.0, 0.0, 0.0))]

    def add(self, t, y_chaser_hill, c_hill_from_body):
        """The relative position of the chaser's CoM at t [m, hill] with the attitude estimate then."""
        while self.t < t - 1e-9:
            h = min(1.0, t - self.t)
            self.x_ref = rk4_step_floats(self._rhs, self.t, self.x_ref, h)
            self.t += h
        self.t = float(t)
        c = np.asarray(c_hill_from_body, dtype=float)
        h_row = np.hstack((cw_transition_matrix(self.n, self.t - self.t0)[:3], c))
        residual = np.asarray(y_chaser_hill, dtype=float) - np.asarray(self.x_ref[:3]) - c @ self.p_prior
        self.info += self.weight * (h_row.T @ h_row)
        self.b += self.weight * (h_row.T @ residual)

    def solve(self):
        """(p [m], its covariance, the combined CoM's (r_hill, v_hill) at the last sample and their 6x6 covariance)."""
        cov = _scaled_inverse(self.info)
        delta = cov @ self.b
        phi = cw_transition_matrix(self.n, self.t - self.t0)
        x = np.asarray(self.x_ref) + phi @ delta[:6]
        return (self.p_prior + delta[6:], cov[6:, 6:], x[:3], x[3:], phi @ cov[:6, :6] @ phi.T)


class TransportNavigation:
    """The combined body's translation in TRANSPORT (issue 17; seed 004 §2.2's x, v with its GPS read as the relative
    position sensor): a ``RelativeNavFilter`` on the combined CoM, r_cm = r_chaser + C c with c the combined CoM from
    the chaser's (the mass-property estimate's M/(m + M) X_s), driven by the accelerometer at the chaser less the
    body's rotation there (seed 004 §2.2: f = a_cm + omega_dot x p + omega x (omega x p), p = -c, omega and omega_dot
    from the attitude filter's rate), and updated by the relative position of the chaser's CoM at the same stamp.
    Its velocity prior covers the drift the excitation left (a few cm/s).

    The accelerometer is taken only where it sees a thrust: a specific force at the CoM above ACCEL_GATE_SIGMA of
    its noise (one firing thruster at its minimum impulse bit gives twenty on the TugRobot). Between firings the
    body coasts on gravity alone, which the filter models (seed 000 eq 22), and integrating the accelerometer's noise
    would only walk the velocity (1e-4 m/s^2 at 10 Hz: 0.1-0.4 mm/s of error, the size of seed 004 §3.2's third
    condition on 50 kg); the filter's white acceleration is then the scenario's transport.nav_accel_psd_m2_s3, what
    CW leaves out of the nonlinear relative motion within a few km (n^2 x^2 / R, 2e-7 m/s^2 at 1 km, over the filter's
    ~30 s memory).

    The combined CoM c is refined over each coast with nothing firing (no force or torque commanded, no thrust seen):
    ``ComCoast`` from the filter's state at the coast's start, at every stamp of COM_PERIOD_S's grid from
    COM_COAST_MIN_S of coast on; the filter then restarts from the coast's state, and the next coast's prior is c with
    its covariance (``refine``)."""

    VELOCITY_SIGMA_MPS = 0.05
    ACCEL_GATE_SIGMA = 5.0
    COMMAND_ERROR_SIGMA = 0.1  # a small firing's delta-v against its command (its thrusters' errors, sub-bit parts)

    def __init__(self, scenario, t_start, com_body_m, com_covariance_m2, mass_kg):
        """t_start: the final mass-property estimate's stamp [s]; com_body_m and its covariance: the combined CoM from
        the chaser's [m, chaser_body] and its 3x3 [m^2]."""
        self.t_start = float(t_start)
        self.com_body_m = np.asarray(com_body_m, dtype=float)
        self.com_covariance_m2 = np.asarray(com_covariance_m2, dtype=float)
        self.mass_kg = float(mass_kg)
        self.scenario = scenario
        self.coast = None  # the ComCoast since the last firing
        self.coast_s = 0.0  # the coast the last refinement took [s]
        self.filter = RelativeNavFilter(relative_nav_config_from_scenario(
            scenario, initial_velocity_sigma_mps=self.VELOCITY_SIGMA_MPS, thrusters=None, chaser_mass_kg=None,
            accel_psd_m2_s3=scenario.post_capture.transport.nav_accel_psd_m2_s3))
        imu = scenario.sensors.chaser_imu
        # The gate: the accelerometer's noise, or the noise of the rotation term omega_dot x p with omega_dot from
        # two gyro samples (on paper_flyby_transport's 2.9 m, 4e-4 m/s^2: above the accelerometer's, and the gate
        # of that took the gyro's noise for thrust and walked the velocity by 0.2-0.6 N s).
        self.accel_sigma_mps2 = max(imu.accel_noise_sigma_mps2, float(np.linalg.norm(self.com_body_m)) * np.sqrt(
            2.0) * imu.gyro_noise_sigma_rad_s * imu.rate_hz)
        self.n = scenario.mean_motion_rad_s
        self.positions = StampedBuffer(8)  # relative positions of the chaser's CoM waiting for their IMU sample
        self.commands = StampedBuffer(8)  # guidance's force commands [N, chaser_body] by the start of their period
        self.last = None  # (t, omega_body) of the previous IMU sample

    def on_position(self, t, r_chaser_hill):
        self.positions.add(t, np.asarray(r_chaser_hill, dtype=float))

    def on_command(self, t, force_body_n, torque_body_n_m=(0.0, 0.0, 0.0)):
        """Guidance's wrench command held from t for one IMU interval: its force a known input where the
        accelerometer does not see it (below the gate: a trim's small pulses on a heavy body, a dump's side forces);
        any firing, a couple's too, ends a coast (its thrusters' errors push)."""
        self.commands.add(t, (np.asarray(force_body_n, dtype=float), bool(np.any(force_body_n) or np.any(
            torque_body_n_m))))

    def on_imu(self, t, estimate, specific_force_body):
        """One IMU sample: the attitude filter's estimate (``ChaserAttitudeEstimate``) and the accelerometer's mean
        specific force since the previous sample [m/s^2, chaser_body] (or None); returns (r_hill, v_hill, covariance)
        of the chaser's CoM, or None before the filter starts, and on COM_PERIOD_S's grid the combined CoM refined
        (``refine``) or None."""
        c_hill = quat_to_matrix(estimate.q_hill_from_body)
        p = -self.com_body_m
        last, self.last = self.last, (t, np.asarray(estimate.omega_body, dtype=float))
        f = self.filter
        quiet = True
        if f.initialized and last is not None and specific_force_body is not None:
            dt = t - last[0]
            omega = self.last[1]
            omega_dot = (omega - last[1]) / dt
            a_cm = np.asarray(specific_force_body, dtype=float) - np.cross(omega_dot, p) - np.cross(
                omega, np.cross(omega, p))
            f.propagate_to(t)
            command = self.commands.last_at_or_before(last[0] + STAMP_TOLERANCE_S)
            commanded = command is not None and abs(command[0] - last[0]) <= STAMP_TOLERANCE_S
            quiet = not (commanded and command[1][1])
            if float(np.linalg.norm(a_cm)) > self.ACCEL_GATE_SIGMA * self.accel_sigma_mps2:  # a thrust (class doc)
                quiet = False
                dv_hill = c_hill @ a_cm * dt
                dv_cross = skew(dv_hill)
                cov = ((self.accel_sigma_mps2 * dt) ** 2 * np.eye(3)
                       + dv_cross @ estimate.attitude_covariance_hill @ dv_cross.T)
                f.add_thrust_error(last[0], t, dv_hill, cov)  # nothing modelled: the whole measured delta-v
            elif commanded and np.any(command[1][0]):
                dv_hill = c_hill @ command[1][0] * (dt / self.mass_kg)  # the commanded delta-v, unseen
                f.add_thrust_error(last[0], t, dv_hill, (self.COMMAND_ERROR_SIGMA * float(np.linalg.norm(
                    dv_hill))) ** 2 * np.eye(3))
        if not quiet:
            self.coast = None
        r_point, v_point = body_point_state(c_hill, self.last[1], p, self.n)  # the chaser's CoM from the combined
        measured = self.positions.last_at_or_before(t + STAMP_TOLERANCE_S)
        if measured is not None and abs(measured[0] - t) <= STAMP_TOLERANCE_S:
            r_cm = measured[1] - r_point
            if not f.initialized:
                f.initialize(t, r_cm)
            elif f.update(t, r_cm).accepted:
                if self.coast is None:
                    s = f.state()
                    # eq 8-9 are linear in the body point: at the unit vectors they give d(r, v)/dp, column by column
                    r_unit, v_unit = body_point_state(c_hill, self.last[1], np.eye(3), self.n)
                    sensitivity = np.vstack((r_unit.T, v_unit.T))
                    self.coast = ComCoast(t, np.concatenate((s.r_hill, s.v_hill)), p, self.com_covariance_m2,
                                          self.n, self.scenario.orbit_radius_m, self.scenario.simulation.dynamics,
                                          self.scenario.sensors.relative_position.noise_sigma_m, s.covariance,
                                          sensitivity)
                self.coast.add(t, measured[1], c_hill)
        refined = self.refine(t) if on_com_grid(t, self.t_start) else None  # on its grid whatever (guidance waits)
        if not f.initialized:
            return None, refined
        if refined is not None:
            r_point, v_point = body_point_state(c_hill, self.last[1], -self.com_body_m, self.n)
        if f.t < t:
            f.propagate_to(t)
        s = f.state()
        return (s.r_hill + r_point, s.v_hill + v_point, s.covariance), refined

    def refine(self, t):
        """At a stamp of COM_PERIOD_S's grid: the combined CoM from the chaser's [m, chaser_body], its 1-sigma per
        axis [m] and the coast it is from [s] (zero: the estimate as it was). From a coast of COM_COAST_MIN_S or
        more, ``ComCoast``'s, and the filter restarts from the coast's state of the combined CoM."""
        if self.coast is not None and self.coast.duration_s >= COM_COAST_MIN_S - 1e-9 and self.coast.t >= t - 1e-9:
            p, p_cov, r_hill, v_hill, x_cov = self.coast.solve()
            self.com_body_m, self.com_covariance_m2, self.coast_s = -p, p_cov, self.coast.duration_s
            self.filter.initialize(t, r_hill, v_hill, x_cov)
        return self.com_body_m, np.sqrt(np.diag(self.com_covariance_m2)), self.coast_s
