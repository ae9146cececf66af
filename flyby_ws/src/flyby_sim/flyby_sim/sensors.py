"""Noisy measurements of the relative position, the target attitude and the chaser's IMU, and their schedule.

Quaternions are (x, y, z, w), scalar last. The attitude measurement is
q_meas = q_hill_from_body * dq, where dq's rotation vector is Gaussian with attitude_sigma_rad per
body axis (a body-frame error, as a camera fixed to the chaser sees the target's markers).

The chaser's IMU (``ImuModel``, six-degree-of-freedom chaser only; docs/chaser_6dof.md), at each sample:

- star tracker (on star-tracker samples only): q_meas = q_hill_from_chaser_body * dq, dq =
  ``random_small_rotation(rng, star_tracker_sigma_rad)`` (a body-frame error, the target sensor's model);
- gyro: omega_meas = omega_body + b + sigma_g n, n ~ N(0, I3); the bias starts at b(0) ~ N(0, sigma_b0^2 I3)
  and walks at every sample before it is read: b_k = b_(k-1) + sigma_bw sqrt(dt) m_k, m_k ~ N(0, I3), dt the
  time since the previous sample (since t = 0 for the first);
- accelerometer: the mean specific force in chaser_body over the interval since the previous sample (t = 0 for
  the first), the thrust acceleration's velocity increment over the interval divided by its length (gravity and
  the relative-orbit terms are not sensed), plus sigma_a n. A real IMU integrates its accelerometers and reports
  the velocity increment of each interval (Savage, "Strapdown inertial navigation integration algorithm design
  part 2: velocity and position algorithms", J. Guidance, Control, and Dynamics 21(2), 1998; Groves,
  "Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems", 2nd ed., 2013, ch. 4), so a
  firing shorter than the interval is sensed in full; the plant gives that increment resolved in chaser_body
  at the sample (``plant.Plant``).

Each sensor draws from its own child stream of the generator given (Generator.spawn), so adding a
sensor, or sampling one at another rate, leaves the others' draws unchanged.
"""

import math
from typing import NamedTuple

import numpy as np

from flyby_sim.dynamics.rotation import quat_multiply, quat_normalize, random_small_rotation


class SensorModel:
    """Relative-position and target-attitude sensors with Gaussian noise."""

    def __init__(self, rng, position_sigma_m, attitude_sigma_rad):
        """rng: numpy.random.Generator; sigmas are 1-sigma per axis [m], [rad]."""
        for name, value in (('position_sigma_m', position_sigma_m),
                            ('attitude_sigma_rad', attitude_sigma_rad)):
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f'{name} must be finite and >= 0, got {value}')
        self.position_sigma_m = position_sigma_m
        self.attitude_sigma_rad = attitude_sigma_rad
        self._rng_position, self._rng_attitude = rng.spawn(2)

    def relative_position(self, r_hill):
        """Noisy chaser position [m] in hill: r_hill + N(0, position_sigma_m^2) per axis."""
        return np.asarray(r_hill, dtype=float) + self.position_sigma_m * self._rng_position.standard_normal(3)

    def target_attitude(self, q_hill_from_body):
        """Noisy unit quaternion q_hill_from_body * dq (module doc)."""
        dq = random_small_rotation(self._rng_attitude, self.attitude_sigma_rad)
        return quat_normalize(quat_multiply(q_hill_from_body, dq))


class ImuSample(NamedTuple):
    """One sample of the chaser's IMU (plain arrays; the estimator takes it without the sensor model).

    q_hill_from_body is the star tracker's attitude of chaser_body in hill (x, y, z, w), None between its
    samples; omega_body_meas the gyro's inertial rate in chaser_body [rad/s]; specific_force_body the
    accelerometer's mean specific force in chaser_body over the interval since the previous sample [m/s^2].
    """

    t: float
    q_hill_from_body: object  # np.ndarray (4,) or None
    omega_body_meas: np.ndarray
    specific_force_body: np.ndarray


class ImuModel:
    """Star tracker, gyro with a random-walk bias and accelerometer of the chaser (module doc)."""

    def __init__(self, rng, star_tracker_sigma_rad, gyro_noise_sigma_rad_s, gyro_bias_sigma_rad_s,
                 gyro_bias_walk_rad_s_sqrt_s, accel_noise_sigma_mps2):
        """rng: numpy.random.Generator (three child streams: star tracker, gyro, accelerometer); the sigmas as
        in the module doc, finite and >= 0. Draws the initial gyro bias b(0) here."""
        for name, value in (('star_tracker_sigma_rad', star_tracker_sigma_rad),
                            ('gyro_noise_sigma_rad_s', gyro_noise_sigma_rad_s),
                            ('gyro_bias_sigma_rad_s', gyro_bias_sigma_rad_s),
                            ('gyro_bias_walk_rad_s_sqrt_s', gyro_bias_walk_rad_s_sqrt_s),
                            ('accel_noise_sigma_mps2', accel_noise_sigma_mps2)):
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f'{name} must be finite and >= 0, got {value}')
        self.star_tracker_sigma_rad = star_tracker_sigma_rad
        self.gyro_noise_sigma_rad_s = gyro_noise_sigma_rad_s
        self.gyro_bias_walk_rad_s_sqrt_s = gyro_bias_walk_rad_s_sqrt_s
        self.accel_noise_sigma_mps2 = accel_noise_sigma_mps2
        self._rng_star, self._rng_gyro, self._rng_accel = rng.spawn(3)
        self._bias = gyro_bias_sigma_rad_s * self._rng_gyro.standard_normal(3)  # b(0)
        self._t_last = 0.0

    @property
    def gyro_bias_rad_s(self):
        """The gyro bias now (after the latest sample's walk) [rad/s], a fresh array."""
        return self._bias.copy()

    def step_bias(self, step_rad_s):
        """The gyro's bias steps by step_rad_s [rad/s] (an injected fault, ``flyby_sim.faults``)."""
        self._bias = self._bias + np.asarray(step_rad_s, dtype=float)

    def sample(self, t, star_tracker, q_hill_from_body, omega_body, specific_force_body):
        """The ImuSample at time t [s] (after the previous sample) of the true attitude, inertial rate in body
        axes [rad/s] and mean specific force over the interval in body axes [m/s^2]; star_tracker: this sample
        includes one.

        Draws per sample: gyro 3 (walk) + 3 (noise), accelerometer 3, star tracker 3 when it samples.
        """
        dt = t - self._t_last
        if not dt >= 0.0:
            raise ValueError(f'IMU sample at t = {t} s precedes the previous one at {self._t_last} s')
        self._t_last = t
        rng = self._rng_gyro
        self._bias = self._bias + (self.gyro_bias_walk_rad_s_sqrt_s * math.sqrt(dt)) * rng.standard_normal(3)
        omega_meas = np.asarray(omega_body, dtype=float) + self._bias + \
            self.gyro_noise_sigma_rad_s * rng.standard_normal(3)
        force_meas = np.asarray(specific_force_body, dtype=float) + \
            self.accel_noise_sigma_mps2 * self._rng_accel.standard_normal(3)
        q_meas = None
        if star_tracker:
            dq = random_small_rotation(self._rng_star, self.star_tracker_sigma_rad)
            q_meas = quat_normalize(quat_multiply(q_hill_from_body, dq))
        return ImuSample(t, q_meas, omega_meas, force_meas)
