"""The combined body's navigation in TRANSPORT (DESIGN §10, docs/transport.md; no ROS): the combined CoM's
translation from the chaser's relative position and IMU (``TransportNavigation``), the combined CoM's covariance from
the final mass-property estimate (``combined_com_covariance``), and its refinement over the coasts with nothing firing
(``ComCoast``), given on COM_PERIOD_S's grid (``on_com_grid``).

Frames: chaser_body axes, vectors from the chaser's CoM, hill as ``flyby_sim.dynamics.orbital``.
"""

import numpy as np

from flyby_estimation.relative_nav import RelativeNavFilter
from flyby_msgs_py.stamped import StampedBuffer
from flyby_msgs_py.wire import STAMP_TOLERANCE_S
from flyby_sim.dynamics.attitude import body_point_state
from flyby_sim.dynamics.orbital import cw_transition_matrix, relative_accel_components, rk4_step_floats
from flyby_sim.dynamics.rotation import quat_to_matrix, skew

# The combined CoM refined by the transport's coasts (``ComCoast``) is given at the stamps on this grid after the final
# estimate (``on_com_grid``; guidance waits for it there), from a coast with nothing firing this long at least.
COM_PERIOD_S = 50.0
COM_COAST_MIN_S = 200.0


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


def _scaled_inverse(a):
    """The inverse of a symmetric positive definite matrix of mixed units, scaled to a unit diagonal first."""
    scale = 1.0 / np.sqrt(np.diag(a))
    return scale[:, None] * np.linalg.inv(scale[:, None] * a * scale[None, :]) * scale[None, :]


class ComCoast:
    """The combined CoM from the chaser's, refined over a coast with nothing firing (docs/transport.md).

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
    the navigation filter, which takes p as known, would carry its error as a velocity n x C dp."""

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
    """The combined body's translation in TRANSPORT (seed 004 §2.2's x, v with its GPS read as the relative
    position sensor): a ``RelativeNavFilter`` on the combined CoM, r_cm = r_chaser + C c with c the combined CoM from
    the chaser's (the mass-property estimate's M/(m + M) X_s), driven by the accelerometer at the chaser less the
    body's rotation there (seed 004 §2.2: f = a_cm + omega_dot x p + omega x (omega x p), p = -c, omega and omega_dot
    from the attitude filter's rate), and updated by the relative position of the chaser's CoM at the same stamp.
    Its velocity prior covers the drift the excitation left (a few cm/s).

    The accelerometer is taken only where it sees a thrust: a specific force at the CoM above ACCEL_GATE_SIGMA of
    its noise (one firing thruster at its minimum impulse bit gives twenty on the TugRobot). Between firings the
    body coasts on gravity alone, which the filter models with the plant's own relative dynamics (seed 000 eq 1), and
    integrating the accelerometer's noise would only walk the velocity (1e-4 m/s^2 at 10 Hz: 0.1-0.4 mm/s of error,
    the size of seed 004 §3.2's third condition on 50 kg); the filter's white acceleration is then
    ``params.TRANSPORT_NAV_ACCEL_PSD_M2_S3``, the integration's error.

    The combined CoM c is refined over each coast with nothing firing (no force or torque commanded, no thrust seen):
    ``ComCoast`` from the filter's state at the coast's start, at every stamp of COM_PERIOD_S's grid from
    COM_COAST_MIN_S of coast on; the filter then restarts from the coast's state, and the next coast's prior is c with
    its covariance (``refine``)."""

    VELOCITY_SIGMA_MPS = 0.05
    GATE_PROBABILITY = 0.9999  # chi2(3) gate on the relative position's NIS
    ACCEL_GATE_SIGMA = 5.0
    COMMAND_ERROR_FLOOR = 0.03  # a small firing's delta-v against its command at least this (parts below the bit)

    def __init__(self, params, t_start, com_body_m, com_covariance_m2, mass_kg):
        """params: the ``params.TransportNavigationParams``; t_start: the final mass-property estimate's stamp [s];
        com_body_m and its covariance: the combined CoM from the chaser's [m, chaser_body] and its 3x3 [m^2]."""
        self.t_start = float(t_start)
        self.com_body_m = np.asarray(com_body_m, dtype=float)
        self.com_covariance_m2 = np.asarray(com_covariance_m2, dtype=float)
        self.mass_kg = float(mass_kg)
        self.params = params
        self.coast = None  # the ComCoast since the last firing
        self.coast_s = 0.0  # the coast the last refinement took [s]
        self.filter = RelativeNavFilter(params.nav.config(initial_velocity_sigma_mps=self.VELOCITY_SIGMA_MPS,
                                                          gate_probability=self.GATE_PROBABILITY))
        # The noise of a_cm: the accelerometer's and that of the rotation term omega_dot x p with omega_dot from two
        # gyro samples (a CoM metres from the chaser's; docs/transport.md), independent, so in quadrature.
        self.accel_sigma_mps2 = float(np.hypot(params.accel_noise_sigma_mps2, float(np.linalg.norm(
            self.com_body_m)) * np.sqrt(2.0) * params.gyro_noise_sigma_rad_s * params.imu_rate_hz))
        self.n = params.nav.mean_motion_rad_s
        self.positions = StampedBuffer(8)  # relative positions of the chaser's CoM waiting for their IMU sample
        self.commands = StampedBuffer(8)  # guidance's force commands [N, chaser_body] by the start of their period
        self.last = None  # (t, omega_body) of the previous IMU sample
        self.firing_samples = 0  # the samples of the firing under way, each commanded (0: none)
        # A commanded firing's delta-v is known to its thrusters' execution errors (``command_error``).
        self.command_error = command_error(params.thrust_magnitude_sigma, params.thrust_misalignment_sigma_rad)

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
            seen = float(np.linalg.norm(a_cm)) > self.ACCEL_GATE_SIGMA * self.accel_sigma_mps2  # a thrust (class doc)
            quiet = not (commanded and command[1][1]) and not seen
            dv_command = c_hill @ command[1][0] * (dt / self.mass_kg) if commanded and np.any(command[1][0]) else None
            self.firing_samples = 0 if dv_command is None else self.firing_samples + 1
            if seen or dv_command is not None:
                f.add_thrust_error(last[0], t, *self._thrust_delta_v(
                    c_hill @ a_cm * dt if seen else None, dv_command, dt, estimate.attitude_covariance_hill))
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
                                          self.n, self.params.nav.radius_m, self.params.dynamics,
                                          self.params.nav.position_sigma_m, s.covariance,
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

    def _thrust_delta_v(self, dv_measured, dv_command, dt, attitude_covariance_hill):
        """(delta-v [m/s, hill], its 3x3 covariance) of a sample's thrust: the accelerometer's (dv_measured, None where
        it sees none) and the command's (dv_command, None where none was given) fused at their inverse covariances,
        the least-variance estimate of the two (the command's on a heavy body, whose small firings the accelerometer
        barely sees; the accelerometer's on a light one); either alone where the other is none, and the
        accelerometer's alone where the two differ beyond ACCEL_GATE_SIGMA of their joint covariance (a thrust the
        command does not explain). A thruster's execution error is the same over a firing, not white as the
        accelerometer's noise: the k-th sample of a firing (``firing_samples``) carries 2k - 1 times one sample's
        variance, so k samples carry k^2 (the error of their sum), and a long firing is the accelerometer's."""
        if dv_command is not None:
            cov_command = (2 * self.firing_samples - 1) * (self.command_error * float(np.linalg.norm(
                dv_command))) ** 2 * np.eye(3)
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
        """At a stamp of COM_PERIOD_S's grid: the combined CoM from the chaser's [m, chaser_body], its 1-sigma per
        axis [m] and the coast it is from [s] (zero: the estimate as it was). From a coast of COM_COAST_MIN_S or
        more, ``ComCoast``'s, and the filter restarts from the coast's state of the combined CoM."""
        if self.coast is not None and self.coast.duration_s >= COM_COAST_MIN_S - 1e-9 and self.coast.t >= t - 1e-9:
            p, p_cov, r_hill, v_hill, x_cov = self.coast.solve()
            self.com_body_m, self.com_covariance_m2, self.coast_s = -p, p_cov, self.coast.duration_s
            self.filter.initialize(t, r_hill, v_hill, x_cov)
        return self.com_body_m, np.sqrt(np.diag(self.com_covariance_m2)), self.coast_s
