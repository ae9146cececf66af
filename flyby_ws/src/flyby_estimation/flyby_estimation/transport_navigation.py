"""The combined body's navigation in TRANSPORT (DESIGN §10, docs/transport.md; no ROS): the combined CoM's
translation and the combined CoM itself from the chaser's relative position and IMU (``TransportNavigation``, on
``combined_com_filter.CombinedComFilter``), the combined CoM's covariance from the final mass-property estimate
(``combined_com_covariance``), the combined CoM given on COM_PERIOD_S's grid (``on_com_grid``).

Frames: chaser_body axes, vectors from the chaser's CoM, hill as ``flyby_sim.dynamics.orbital``.
"""

import numpy as np

from flyby_estimation.combined_com_filter import CombinedComFilter
from flyby_estimation.thrust_isolation import Allocator
from flyby_msgs_py.stamped import StampedBuffer
from flyby_msgs_py.wire import STAMP_TOLERANCE_S
from flyby_sim.dynamics.attitude import body_point_state
from flyby_sim.dynamics.rotation import quat_to_matrix, skew

# The combined CoM the navigation estimates is given at the stamps on this grid after the final estimate
# (``on_com_grid``; guidance waits for it there, and flies it until the next).
COM_PERIOD_S = 50.0
# The combined CoM is learnt only while the body turns no faster than this many times the orbit's rate (held): in a
# slew the couples' execution errors and the accelerometer's rotation term leave velocity errors the filter's
# covariance does not cover, which the fast-turning C p would take as the CoM (docs/transport.md).
HELD_RATE_ORBITS = 2.0


def combined_com_covariance(chaser_mass_kg, estimate):
    """The covariance [m^2] of the combined CoM from the chaser's, c = M X_s / (m + M) (seed 004 §2.2,
    ``combined_body.combined_mass_properties``), from a ``mass_properties_model.MassPropertyEstimate``'s 1-sigma of the
    target's mass M and CoM X_s (to first order)."""
    m, big_m = float(chaser_mass_kg), float(estimate.target_mass_kg)
    total = m + big_m
    x_s = np.asarray(estimate.target_com_body_m, dtype=float)
    dc_dm = m / total**2 * x_s
    return ((big_m / total) ** 2 * np.diag(np.asarray(estimate.com_sigma_m, dtype=float) ** 2)
            + estimate.mass_sigma_kg**2 * np.outer(dc_dm, dc_dm))


def command_error(magnitude_sigma, misalignment_sigma_rad):
    """The relative 1-sigma of a commanded firing's delta-v: its thrusters' magnitude and direction errors, at least
    TransportNavigation.COMMAND_ERROR_FLOOR."""
    return max(float(np.hypot(magnitude_sigma, misalignment_sigma_rad)), TransportNavigation.COMMAND_ERROR_FLOOR)


def on_com_grid(t, t_start):
    """True for a stamp t [s] of COM_PERIOD_S's grid after t_start, the final mass-property estimate's."""
    return t > t_start + STAMP_TOLERANCE_S and abs(t - round(t / COM_PERIOD_S) * COM_PERIOD_S) <= STAMP_TOLERANCE_S


class TransportNavigation:
    """The combined body's translation in TRANSPORT (seed 004 §2.2's x, v with its GPS read as the relative
    position sensor): a ``CombinedComFilter`` of the combined CoM and of the chaser's CoM from it (p = -c, c the
    mass-property estimate's M/(m + M) X_s for its prior), driven by the accelerometer at the chaser less the body's
    rotation there (seed 004 §2.2: f = a_cm + omega_dot x p + omega x (omega x p), omega and omega_dot from the
    attitude filter's rate) and updated by the relative position of the chaser's CoM at the same stamp. Its velocity
    prior covers the drift the excitation left (a few cm/s).

    The accelerometer is taken only where it sees a thrust: a specific force at the CoM above ACCEL_GATE_SIGMA of
    its noise (one firing thruster at its minimum impulse bit gives twenty on the TugRobot). Between firings the
    body coasts on gravity alone, which the filter models with the plant's own relative dynamics (seed 000 eq 1), and
    integrating the accelerometer's noise would only walk the velocity (1e-4 m/s^2 at 10 Hz: 0.1-0.4 mm/s of error,
    the size of seed 004 §3.2's third condition on 50 kg); the filter's white acceleration is then
    ``params.TRANSPORT_NAV_ACCEL_PSD_M2_S3``, the integration's error. A firing the accelerometer barely sees is
    guidance's command, a known input (``on_command``, ``_thrust_delta_v``).

    The combined CoM the filter estimates is given on COM_PERIOD_S's grid (``refine``), with the time since the last
    firing; the chaser's state it returns is the combined CoM's moved by the CoM last given, the one guidance flies."""

    VELOCITY_SIGMA_MPS = 0.05
    GATE_PROBABILITY = 0.9999  # chi2(3) gate on the relative position's NIS
    ACCEL_GATE_SIGMA = 5.0
    COMMAND_ERROR_FLOOR = 0.03  # a small firing's delta-v against its command at least this (parts below the bit)

    def __init__(self, params, t_start, com_body_m, com_covariance_m2, mass_kg):
        """params: the ``params.TransportNavigationParams``; t_start: the final mass-property estimate's stamp [s];
        com_body_m and its covariance: the combined CoM from the chaser's [m, chaser_body] and its 3x3 [m^2]."""
        self.t_start = float(t_start)
        self.com_body_m = np.asarray(com_body_m, dtype=float)
        self.mass_kg = float(mass_kg)
        self.params = params
        self.t_quiet = self.t_start  # the end of the last firing [s]
        self.filter = CombinedComFilter(params.nav.config(initial_velocity_sigma_mps=self.VELOCITY_SIGMA_MPS,
                                                          gate_probability=self.GATE_PROBABILITY),
                                        -self.com_body_m, com_covariance_m2)
        # The noise of a_cm: the accelerometer's and that of the rotation term omega_dot x p with omega_dot from two
        # gyro samples (a CoM metres from the chaser's; docs/transport.md), independent, so in quadrature.
        self.accel_sigma_mps2 = float(np.hypot(params.accel_noise_sigma_mps2, float(np.linalg.norm(
            self.com_body_m)) * np.sqrt(2.0) * params.gyro_noise_sigma_rad_s * params.imu_rate_hz))
        self.n = params.nav.mean_motion_rad_s
        self.positions = StampedBuffer(8)  # relative positions of the chaser's CoM waiting for their IMU sample
        self.commands = StampedBuffer(8)  # guidance's commands by the start of their period (``on_command``)
        self.allocator = Allocator(params.thruster_layout)
        self.period_s = 1.0 / params.imu_rate_hz
        self.last = None  # (t, omega_body) of the previous IMU sample
        self.firing_samples = 0  # the samples of the firing under way, each commanded (0: none)
        # A commanded firing's delta-v is known to its thrusters' execution errors (``command_error``).
        self.command_error = command_error(params.thrust_magnitude_sigma, params.thrust_misalignment_sigma_rad)

    def on_position(self, t, r_chaser_hill):
        self.positions.add(t, np.asarray(r_chaser_hill, dtype=float))

    def on_command(self, t, force_body_n, torque_body_n_m=(0.0, 0.0, 0.0)):
        """Guidance's wrench command held from t for one IMU interval: its force a known input where the
        accelerometer does not see it (below the gate: a trim's small pulses on a heavy body, a dump's side forces),
        known to the execution errors of every thruster it fires (allocated as the plant allocates it,
        ``thrust_isolation.Allocator``; at least its force's): a couple's too, whose net force is nil and whose
        thrusters' errors push."""
        force = np.asarray(force_body_n, dtype=float)
        thrusts, _ = self.allocator.wrench(tuple(force.tolist()), tuple(np.asarray(torque_body_n_m, dtype=float)
                                                                         .tolist()), self.period_s)
        self.commands.add(t, (force, max(float(np.linalg.norm(thrusts)), float(np.linalg.norm(force)))))

    def on_imu(self, t, estimate, specific_force_body):
        """One IMU sample: the attitude filter's estimate (``ChaserAttitudeEstimate``) and the accelerometer's mean
        specific force since the previous sample [m/s^2, chaser_body] (or None); returns (r_hill, v_hill, covariance)
        of the chaser's CoM, or None before the filter starts, and on COM_PERIOD_S's grid the combined CoM
        (``refine``) or None."""
        c_hill = quat_to_matrix(estimate.q_hill_from_body)
        p = -self.com_body_m
        last, self.last = self.last, (t, np.asarray(estimate.omega_body, dtype=float))
        f = self.filter
        if f.initialized and last is not None and specific_force_body is not None:
            dt = t - last[0]
            omega = self.last[1]
            omega_dot = (omega - last[1]) / dt
            a_cm = np.asarray(specific_force_body, dtype=float) - np.cross(omega_dot, p) - np.cross(
                omega, np.cross(omega, p))
            f.propagate_to(t)
            command = self.commands.last_at_or_before(last[0] + STAMP_TOLERANCE_S)
            commanded = command is not None and abs(command[0] - last[0]) <= STAMP_TOLERANCE_S
            seen = float(np.linalg.norm(a_cm)) > self.ACCEL_GATE_SIGMA * self.accel_sigma_mps2  # a thrust (class doc)
            firing = commanded and command[1][1] > 0.0
            self.firing_samples = self.firing_samples + 1 if firing else 0
            if seen or firing:
                dv_command = (c_hill @ command[1][0] * (dt / self.mass_kg), command[1][1] * dt / self.mass_kg) \
                    if firing else None
                f.add_thrust(last[0], t, *self._thrust_delta_v(
                    c_hill @ a_cm * dt if seen else None, dv_command, dt, estimate.attitude_covariance_hill))
                self.t_quiet = t
        measured = self.positions.last_at_or_before(t + STAMP_TOLERANCE_S)
        if measured is not None and abs(measured[0] - t) <= STAMP_TOLERANCE_S:
            if not f.initialized:
                f.initialize(t, measured[1], c_hill)
            else:
                f.update(t, measured[1], c_hill, float(np.linalg.norm(self.last[1])) <= HELD_RATE_ORBITS * self.n)
        refined = self.refine(t) if on_com_grid(t, self.t_start) else None  # on its grid whatever (guidance waits)
        if not f.initialized:
            return None, refined
        f.propagate_to(t)
        r_cm, v_cm, covariance = f.state()
        r_point, v_point = body_point_state(c_hill, self.last[1], -self.com_body_m, self.n)  # the chaser's CoM
        return (r_cm + r_point, v_cm + v_point, covariance), refined

    def _thrust_delta_v(self, dv_measured, dv_command, dt, attitude_covariance_hill):
        """(delta-v [m/s, hill], its 3x3 covariance) of a sample's thrust: the accelerometer's (dv_measured, None where
        it sees none) and the command's (dv_command: its delta-v and the root sum square of its thrusters' delta-vs,
        None where none was given) fused at their inverse covariances, the least-variance estimate of the two (the
        command's on a heavy body, whose small firings the accelerometer barely sees; the accelerometer's on a light
        one); either alone where the other is none, and the accelerometer's alone where the two differ beyond
        ACCEL_GATE_SIGMA of their joint covariance (a thrust the command does not explain). A thruster's execution
        error is the same over a firing, not white as the accelerometer's noise: the k-th sample of a firing
        (``firing_samples``) carries 2k - 1 times one sample's variance, so k samples carry k^2 (the error of their
        sum), and a long firing is the accelerometer's."""
        if dv_command is not None:
            dv_command, dv_thrusters = dv_command
            cov_command = (2 * self.firing_samples - 1) * (self.command_error * dv_thrusters) ** 2 * np.eye(3)
            if dv_measured is None:
                return dv_command, cov_command
        dv_cross = skew(dv_measured)
        cov_measured = (self.accel_sigma_mps2 * dt) ** 2 * np.eye(3) + dv_cross @ attitude_covariance_hill @ dv_cross.T
        if dv_command is None:
            return dv_measured, cov_measured
        miss = dv_measured - dv_command
        if miss @ np.linalg.solve(cov_measured + cov_command, miss) > self.ACCEL_GATE_SIGMA**2:
            return dv_measured, cov_measured
        info_measured, info_command = np.linalg.inv(cov_measured), np.linalg.inv(cov_command)
        cov = np.linalg.inv(info_measured + info_command)
        return cov @ (info_measured @ dv_measured + info_command @ dv_command), cov

    def refine(self, t):
        """At a stamp of COM_PERIOD_S's grid: the combined CoM from the chaser's [m, chaser_body], the filter's, its
        1-sigma per axis [m] and the time since the last firing [s]; guidance flies it from this stamp on."""
        self.com_body_m = -self.filter.p.copy()
        return self.com_body_m, np.sqrt(np.diag(self.filter.p_covariance_m2)), t - self.t_quiet

    def velocity_sigma_mps(self):
        """The combined CoM's velocity 1-sigma [m/s], its largest direction (the filter's, with what it does not
        know of the combined CoM)."""
        return self.filter.velocity_sigma_mps()
