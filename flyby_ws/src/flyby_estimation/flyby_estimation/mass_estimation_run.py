"""What the estimator does after the capture (DESIGN §10; no ROS): the prior of the target's mass
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

from flyby_estimation.mass_properties import MassPropertyFilter, MassPropertyFilterConfig
from flyby_estimation.mass_properties_excitation import excitation_firings, thruster_firings
from flyby_estimation.mass_properties_model import MassPropertyPrior, j_from_moments
from flyby_msgs_py.wire import STAMP_TOLERANCE_S
from flyby_sim.dynamics.orbital import q_eci_from_body
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_matrix,
    quat_from_rotation_vector,
    quat_multiply,
    quat_rotate,
)

PUBLISH_EVERY = 10  # IMU samples between two published estimates (1 s at 10 Hz)
SAMPLES_KEPT = 600  # IMU samples after the capture kept for a late announcement of the excitation
# The filter's start: position and velocity are not observed (no position sensor after the capture); the rate's
# sigma covers the gyro's noise and bias error.
_STATE_SIGMAS = (1.0, 0.1)  # r [m], v [m/s]
_RATE_SIGMA_RAD_S = 1e-4
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


def attachment_snapshot(p):
    """The CaptureSnapshot of a run that starts attached (scenario post_capture.start attached, seed 004 §3.1): the
    attachment of post_capture.attachment as the crew or the docking fixture knows it, its CoM X_s and the target's
    axes each drawn with the prior's sigma (prior_com_sigma_m, prior_axes_sigma_deg) from a stream of the seed, at
    the chaser's initial position and attitude. p: the ``params.MassEstimationParams``."""
    attachment = p.attachment
    rng = np.random.default_rng([p.seed, _ATTACHMENT_STREAM])
    z = rng.standard_normal(6)
    x_s = np.asarray(attachment.target_com_chaser_body_m, dtype=float)
    x_s = x_s + p.prior_com_sigma_m * z[:3]
    sigma_rad = p.prior_axes_sigma_rad
    q_chaser = attachment.q_hill_from_chaser_body0
    q_chaser_from_target = quat_multiply(attachment.q_chaser_from_target, quat_from_rotation_vector(sigma_rad * z[3:]))
    r_chaser_hill = -quat_rotate(q_chaser, x_s)
    return CaptureSnapshot(0.0, r_chaser_hill, q_chaser, quat_multiply(q_chaser, q_chaser_from_target),
                           sigma_rad ** 2 * np.eye(3),
                           tuple(np.asarray(attachment.chaser_position_hill0_m, dtype=float) - r_chaser_hill))


def principal_axes(inertia_kg_m2):
    """(principal moments (3,) ascending [kg m^2], q_body_from_principal (x, y, z, w)) of an inertia matrix, the
    axes a right-handed frame."""
    moments, axes = np.linalg.eigh(0.5 * (np.asarray(inertia_kg_m2, dtype=float) + np.asarray(inertia_kg_m2).T))
    if np.linalg.det(axes) < 0.0:
        axes[:, 2] = -axes[:, 2]
    return moments, quat_from_matrix(axes)


def mass_property_prior(p, snapshot, arm_displacement_body_m=(0.0, 0.0, 0.0), arm_rotation_body_rad=(0.0, 0.0, 0.0)):
    """The MassPropertyPrior of the target at the lock: the capture's estimates moved by the arm's deflection
    (module doc). p: the ``params.MassEstimationParams``."""
    rng = np.random.default_rng([p.seed, _PRIOR_STREAM])
    moments, q_target_from_principal = principal_axes(p.target_inertia)
    z = rng.standard_normal(4)
    mass_kg = p.target_mass_kg * (1.0 + p.prior_mass_sigma * z[0])
    moments_prior = moments * (1.0 + p.prior_moments_sigma * z[1:])
    # The moments' relative sigma in the filter's j (a diagonal P0: the map's Jacobian, its cross terms left out).
    jac = np.empty((3, 3))
    for k in range(3):
        d = np.zeros(3)
        d[k] = 1e-6 * moments_prior[k]
        jac[:, k] = (j_from_moments(moments_prior + d) - j_from_moments(moments_prior - d)) / (2.0 * d[k])
    j_cov = jac @ np.diag((p.prior_moments_sigma * moments_prior) ** 2) @ jac.T
    q_capture = quat_multiply(quat_conjugate(snapshot.q_hill_from_chaser), snapshot.q_hill_from_target)
    rotation = quat_from_rotation_vector(arm_rotation_body_rad)
    q_chaser_from_target = quat_multiply(rotation, q_capture)
    handle = quat_rotate(q_capture, p.grasp_point_body_m)
    x_s = (-snapshot.r_chaser_body + np.asarray(arm_displacement_body_m, dtype=float) + handle
           - quat_rotate(rotation, handle))
    axes_sigma_rad = (math.sqrt(float(np.linalg.eigvalsh(snapshot.target_attitude_covariance_hill)[-1]))
                      if p.prior_axes_sigma_rad is None else p.prior_axes_sigma_rad)
    return MassPropertyPrior(float(mass_kg), tuple(x_s),
                             tuple(quat_multiply(q_chaser_from_target, q_target_from_principal)),
                             tuple(moments_prior), p.prior_mass_sigma * p.target_mass_kg,
                             p.prior_com_sigma_m, axes_sigma_rad, tuple(np.sqrt(np.diag(j_cov))))


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
    estimate: object  # mass_properties_model.MassPropertyEstimate
    final: bool


class MassEstimationRun:
    """The filter over the excitation (module doc). ``start`` once the excitation's start is known, ``on_sample``
    at every IMU sample after the capture; both return TargetInertiaEstimates."""

    def __init__(self, params, chaser_mass_kg):
        """params: the ``params.MassEstimationParams``; chaser_mass_kg: the chaser's mass at the capture [kg]."""
        self.params = params
        self.prior = None
        self.chaser_mass_kg = chaser_mass_kg
        self.period_s = 1.0 / params.imu_rate_hz
        self.window_s = params.window_s
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
        p = self.params
        config = MassPropertyFilterConfig(
            self.chaser_mass_kg, tuple(map(tuple, p.chaser_inertia.tolist())),
            gyro_sigma_rad_s=p.gyro_noise_sigma_rad_s, accel_sigma_mps2=p.accel_noise_sigma_mps2,
            attitude_sigma_rad=p.star_tracker_sigma_rad, h_wheels_body_n_m_s=self.h_wheels,
            max_step_s=self.period_s, accel_interval_s=self.period_s,
            thrust_magnitude_sigma=p.thrust_magnitude_sigma,
            thrust_misalignment_sigma_rad=p.thrust_misalignment_sigma_rad,
            thrust_error_states=True,  # the plant draws them once per run: constant, estimated
            exhaust_velocity_mps=p.thruster_layout.exhaust_velocity_mps,
            gyro_bias_walk_rad_s_sqrt_s=p.gyro_bias_walk_rad_s_sqrt_s,
            accel_psd_m2_s3=0.0, angular_accel_psd_rad2_s3=0.0)  # what the combined body has (module doc)
        firings = thruster_firings(p.thruster_layout, excitation_firings(p.excitation, self.t_start), self.period_s)
        attitude_sigma = max(p.star_tracker_sigma_rad, 1e-6)
        return MassPropertyFilter(config, self.prior, s.t, np.zeros(3), np.zeros(3), s.q_eci_from_body, s.omega_body,
                                  (*_STATE_SIGMAS, attitude_sigma, _RATE_SIGMA_RAD_S), firings,
                                  s.gyro_bias_covariance)
