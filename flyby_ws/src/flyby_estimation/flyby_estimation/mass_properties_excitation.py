"""Excitation for the mass-property filter: seed 004 Table 1's thruster sequence, the simulated experiment, and
a sequence chosen for observability (most information at a fuel bound), which seed 004 §4 leaves as future work.

Reading of Table 1 (its columns: firing [s], holding [s], level [%], theta [deg], psi [deg]): each row is one
firing of the TugRobot's thruster starting at "firing" and lasting "holding", at "level" percent of its
maximum thrust, pushing the combined body along

    d(theta, psi) = (cos theta cos psi, cos theta sin psi, sin theta)   (chaser_body axes)

(theta the elevation from the body x-y plane, psi the azimuth from +x; 0, 0 pushes toward the target, whose
CoM is on +x). The table names neither the thruster's maximum thrust nor its position; we take
``TABLE1_MAX_THRUST_N`` = 10 N (the chaser's thrusters) at ``TABLE1_THRUSTER_POSITION_BODY_M`` on the
TugRobot's rear face, off its axis so that every direction turns the body. Seed 004 §3.1's bodies are
``tugrobot_case``.

The chosen sequence: K firings of the same thruster, each a direction from a grid, placed on a grid of
start times inside the excitation window; a candidate's figure of merit is the log-determinant of the
information the filter gains on the ten target parameters (log det P0_params - log det P_params after
the window, P from the filter's own Riccati recursion along the nominal trajectory: a D-optimal design);
every candidate uses the same total impulse (fuel = impulse / (Isp g0)).

In a mission (scenario post_capture, DESIGN §10) the chaser has no such gimballed thruster: each firing is the
wrench (F, X_f x F) about the chaser's CoM, commanded on /guidance/wrench and held in steps of the control period,
which the plant allocates on the chaser's own thrusters (``actuators.allocate_wrench`` and ``fire`` with the
minimum impulse bit over the hold); ``thruster_firings`` is that allocation as the filter's known input, each
thruster at its true position (``excitation_firings`` the sequence itself, from the excitation's start).
"""

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from flyby_estimation.mass_properties import MassPropertyFilter, MassPropertyFilterConfig
from flyby_estimation.mass_properties_model import PARAMETER_SLICE, MassPropertyPrior, j_from_moments, moments_from_j
from flyby_sim.dynamics.actuators import allocate_wrench, fire
from flyby_sim.dynamics.combined_body import (
    CombinedState,
    Firing,
    combined_mass_properties,
    inertia_from_principal,
    simulate_combined_body,
    specific_force_body,
)
from flyby_sim.dynamics.rotation import quat_from_rotation_vector, quat_multiply, random_small_rotation

TABLE1_MAX_THRUST_N = 10.0
TABLE1_THRUSTER_POSITION_BODY_M = (-0.3, 0.1, 0.1)
# Table 1: (firing [s], holding [s], level [%], theta [deg], psi [deg]).
TABLE1_ROWS = (
    (1.0, 1.0, 100.0, 0.0, 0.0),
    (3.0, 0.5, 50.0, 80.0, 0.0),
    (5.0, 0.5, 50.0, 80.0, 0.0),
    (7.0, 0.5, 50.0, -80.0, 0.0),
    (9.0, 0.5, 50.0, -80.0, 0.0),
    (11.0, 0.5, 50.0, 0.0, -45.0),
    (13.0, 0.5, 50.0, 0.0, 45.0),
    (15.0, 0.5, 50.0, 45.0, 45.0),
    (19.0, 0.5, 50.0, -45.0, -45.0),
)
# The sequence choose_sequence picked for §3.1's case (seed [16], 16 candidates, docs/post_capture.md): nine
# firings, each 0.3 s (its 1/3 s on the 0.1 s IMU grid), graded: the first three at 10 % keep the first responses
# inside the filter's linear range from the prior's few percent, the rest at full thrust (18.9 N s: no more
# impulse than Table 1's 30).
CHOSEN_ROWS = (
    (1.0, 0.3, 10.0, 45.0, -135.0),
    (2.0, 0.3, 10.0, -45.0, -90.0),
    (3.0, 0.3, 10.0, 80.0, 90.0),
    (6.0, 0.3, 100.0, 80.0, -45.0),
    (7.0, 0.3, 100.0, 45.0, 45.0),
    (8.0, 0.3, 100.0, 45.0, -135.0),
    (9.0, 0.3, 100.0, 0.0, 90.0),
    (10.0, 0.3, 100.0, 80.0, 90.0),
    (13.0, 0.3, 100.0, 0.0, 0.0),
)
EXCITATIONS = {'table1': TABLE1_ROWS, 'chosen': CHOSEN_ROWS}  # scenario post_capture.mass_estimation.excitation
PRIOR_AXES_SIGMA_RAD = math.radians(1.0)
STATE_SIGMAS = (1.0, 0.1, math.radians(1.0), 0.01)  # r [m], v [m/s], attitude [rad], omega [rad/s] at the start


def thrust_direction(theta_deg, psi_deg):
    """Unit force direction d(theta, psi) in chaser_body axes (module doc)."""
    th, ps = math.radians(theta_deg), math.radians(psi_deg)
    return (math.cos(th) * math.cos(ps), math.cos(th) * math.sin(ps), math.sin(th))


def firings_from_rows(rows, max_thrust_n=TABLE1_MAX_THRUST_N, position_body_m=TABLE1_THRUSTER_POSITION_BODY_M):
    """Firings of rows (firing [s], holding [s], level [%], theta [deg], psi [deg]) of one thruster."""
    firings = []
    for t0, hold, level, theta, psi in rows:
        f = max_thrust_n * level / 100.0
        firings.append(Firing(float(t0), float(hold), tuple(position_body_m),
                              tuple(f * c for c in thrust_direction(theta, psi))))
    return tuple(firings)


def table1_firings():
    """Seed 004 Table 1's sequence as firings (module doc)."""
    return firings_from_rows(TABLE1_ROWS)


def excitation_firings(name, t_start_s):
    """The excitation ``name`` ('table1' or 'chosen', EXCITATIONS) as firings of Table 1's thruster from t_start_s
    [s] (module doc)."""
    return tuple(f._replace(t_start_s=t_start_s + f.t_start_s) for f in firings_from_rows(EXCITATIONS[name]))


def firing_wrench(firing):
    """(force [N], torque about the chaser CoM [N m]) of a firing, chaser_body axes: (F, X_f x F)."""
    force = np.asarray(firing.force_body_n, dtype=float)
    return force, np.cross(firing.position_body_m, force)


def thruster_firings(layout, firings, hold_s):
    """Each firing's wrench (``firing_wrench``) as the plant fires it held over hold_s [s] (module doc): the firings
    of the layout's thrusters (nominal thrust, at their positions from the chaser CoM), one per thruster that
    fires."""
    out = []
    for f in firings:
        thrusts = fire(layout, allocate_wrench(layout, *firing_wrench(f)).thrusts_n, hold_s).thrusts_n
        out.extend(Firing(f.t_start_s, f.duration_s, tuple(p.tolist()), tuple((thrust * d).tolist()))
                   for p, d, thrust in zip(layout.positions_body_m, layout.force_directions_body, thrusts.tolist(),
                                           strict=True) if thrust > 0.0)
    return tuple(out)


def total_impulse_n_s(firings):
    """Sum of |F| dt over the firings [N s]."""
    return sum(f.impulse_n_s for f in firings)


def _successive_xyz(angles_deg):
    """The quaternion of successive rotations by angles_deg [deg] about the (turned) body x, y and z axes."""
    q = np.array((0.0, 0.0, 0.0, 1.0))
    for k, angle in enumerate(angles_deg):
        q = quat_multiply(q, quat_from_rotation_vector(math.radians(angle) * np.eye(3)[k]))
    return q


class TugrobotCase(NamedTuple):
    """Seed 004 §3.1 / Table 1: the TugRobot (chaser) and the material satellite (target) joined."""

    chaser_mass_kg: float = 30.0
    chaser_principal_moments_kg_m2: tuple = (2.0, 3.0, 3.0)
    r0_m: tuple = (10.0, 5.0, 5.0)
    v0_mps: tuple = (0.0, 0.1, 0.0)
    attitude0_deg: tuple = (20.0, 10.0, 0.0)  # roll, pitch, yaw (x-y-z body rotations), our reading
    omega0_body: tuple = (0.0, 0.0, 0.1)
    target_mass_kg: float = 20.0
    target_principal_moments_kg_m2: tuple = (2.0, 1.5, 1.5)
    target_com_body_m: tuple = (0.5, 0.0, 0.0)
    target_axes_deg: tuple = (0.0, 0.0, 0.0)  # principal axes aligned with the TugRobot's

    @property
    def q_inertial_from_body0(self):
        """Roll, pitch, yaw as successive rotations about body x, y, z (the attitude angles of Table 1)."""
        return _successive_xyz(self.attitude0_deg)

    @property
    def q_body_from_principal(self):
        return _successive_xyz(self.target_axes_deg)

    @property
    def chaser_inertia_body(self):
        return np.diag(self.chaser_principal_moments_kg_m2)

    def combined(self):
        """The true combined mass properties (combined_body.combined_mass_properties)."""
        i_s = inertia_from_principal(self.target_principal_moments_kg_m2, self.q_body_from_principal)
        return combined_mass_properties(self.chaser_mass_kg, self.chaser_inertia_body, self.target_mass_kg,
                                        self.target_com_body_m, i_s)


class Measurements(NamedTuple):
    """A simulated experiment: truth and the sensors' samples."""

    t_s: np.ndarray  # (N,) IMU stamps
    truth: np.ndarray  # (N, 13) r, v, q, omega
    gyro: np.ndarray  # (N, 3)
    accel: np.ndarray  # (N, 3)
    accel_true: np.ndarray  # (N, 3) the specific force without noise
    attitude: np.ndarray  # (N, 4), a sample every attitude_every IMU samples (others nan)
    attitude_every: int


def simulate_experiment(case, firings, duration_s, config, rng, imu_rate_hz=10.0, attitude_every=5):
    """The combined body's truth (combined_body.simulate_combined_body) sampled by a gyro, an accelerometer at
    config.accel_position_body_m and a star tracker with the config's sigmas (white, drawn from rng)."""
    props = case.combined()
    n = int(round(duration_s * imu_rate_hz)) + 1
    t = np.arange(n) / imu_rate_hz
    state0 = CombinedState(np.asarray(case.r0_m, float), np.asarray(case.v0_mps, float), case.q_inertial_from_body0,
                           np.asarray(case.omega0_body, float))
    truth, omega_dot, forces = simulate_combined_body(props, state0, firings, t)
    accel_true = np.array([specific_force_body(props, truth[i, 10:13], omega_dot[i], forces[i],
                                               config.accel_position_body_m) for i in range(n)])
    gyro = truth[:, 10:13] + config.gyro_sigma_rad_s * rng.standard_normal((n, 3))
    accel = accel_true + config.accel_sigma_mps2 * rng.standard_normal((n, 3))
    attitude = np.full((n, 4), np.nan)
    for i in range(0, n, attitude_every):
        attitude[i] = quat_multiply(truth[i, 6:10], random_small_rotation(rng, config.attitude_sigma_rad))
    return Measurements(t, truth, gyro, accel, accel_true, attitude, attitude_every)


def default_prior(case, rng=None, mass_sigma_kg=0.5, com_sigma_m=0.01, axes_sigma_rad=PRIOR_AXES_SIGMA_RAD,
                  j_sigma=(0.03, 0.03, 0.02)):
    """A prior around the truth; with rng its mean is drawn from it (a consistent start), else the truth. From the
    default spread (2.5 % of the mass, 1 cm, 1 deg, about 3 % of the moments) the filter's errors are small and,
    relinearized, its NEES inside the expected band on both sequences (the forward filter's 1.4 to 2.9 times it);
    from a ten times wider one it ends overconfident (mass_properties module doc, docs/post_capture.md)."""
    mass = case.target_mass_kg
    com = np.asarray(case.target_com_body_m, dtype=float)
    q = case.q_body_from_principal
    j = j_from_moments(case.target_principal_moments_kg_m2)
    if rng is not None:
        mass = mass + mass_sigma_kg * rng.standard_normal()
        com = com + com_sigma_m * rng.standard_normal(3)
        q = quat_multiply(q, random_small_rotation(rng, axes_sigma_rad))
        j = j + np.asarray(j_sigma) * rng.standard_normal(3)
    return MassPropertyPrior(float(mass), tuple(com), tuple(q), tuple(moments_from_j(j)), mass_sigma_kg,
                             com_sigma_m, axes_sigma_rad, tuple(j_sigma))


def run_filter(case, firings, meas, config, prior, state_sigmas=STATE_SIGMAS, keep_history=False):
    """The filter over a simulated experiment, started at the first stamp from the first star-tracker and gyro
    samples (which it then does not fuse again) and the true position and velocity, each with state_sigmas; the
    later samples fused in order. Returns (filter, its estimate after each IMU sample if keep_history else [])."""
    t0 = float(meas.t_s[0])
    f = MassPropertyFilter(config, prior, t0, meas.truth[0, 0:3], meas.truth[0, 3:6], meas.attitude[0], meas.gyro[0],
                           state_sigmas, firings)
    history = []
    for i, t in enumerate(meas.t_s.tolist()[1:], start=1):
        f.on_imu(t, meas.gyro[i], meas.accel[i])
        if i % meas.attitude_every == 0:
            f.update(t, meas.attitude[i])
        if keep_history:
            history.append(f.state())
    return f, history


def tugrobot_filter_config(case, **overrides):
    """MassPropertyFilterConfig of the TugRobot case (the chaser IMU's sigmas, accelerometer at the chaser CoM), its
    process noise the experiment's: none. ``simulate_experiment``'s truth is the filter's own model (seed 004 §2.2's
    equations of motion by DOP853 at rtol 1e-11; the filter's RK4 in 0.1 s steps stays within 3e-9 rad/s of it, 3e-4
    of a gyro sigma, over either sequence) with
    no unmodelled force or torque, so any angular_accel_psd would tell the filter of a rate random walk that is not
    there: the default 1e-12 rad^2/s^3 (a 5e-6 rad/s spread over 25 s) masks the slow gyroscopic drift that carries
    the split of the cylinder's two equal moments, and j2's error came out at half its sigma
    (docs/post_capture.md)."""
    overrides = {'accel_psd_m2_s3': 0.0, 'angular_accel_psd_rad2_s3': 0.0, **overrides}
    return MassPropertyFilterConfig(case.chaser_mass_kg, tuple(map(tuple, case.chaser_inertia_body.tolist())),
                                    **overrides)


def information_gain(case, firings, duration_s, config, prior, imu_rate_hz=4.0, attitude_every=2, max_step_s=0.25):
    """log det P0_params - log det P_params after duration_s of the filter's covariance recursion on the noise-free
    truth (the design figure of merit, module doc), with the IMU at imu_rate_hz and steps of max_step_s for speed:
    a ranking of candidates, not the filter's figures."""
    config = dataclasses.replace(config, max_step_s=max_step_s)
    meas = simulate_experiment(case, firings, duration_s, config, np.random.default_rng(0), imu_rate_hz,
                               attitude_every)
    attitude = np.full_like(meas.attitude, np.nan)
    attitude[::attitude_every] = meas.truth[::attitude_every, 6:10]
    noise_free = meas._replace(gyro=meas.truth[:, 10:13], accel=meas.accel_true, attitude=attitude)
    f, _ = run_filter(case, firings, noise_free, config, prior)
    p0 = np.diag(np.concatenate(([prior.mass_sigma_kg], [prior.axes_sigma_rad] * 3, [prior.com_sigma_m] * 3,
                                 prior.j_sigma)) ** 2)
    return float(np.linalg.slogdet(p0)[1] - np.linalg.slogdet(f.covariance[PARAMETER_SLICE, PARAMETER_SLICE])[1])



# Directions of the candidate firings: elevations and azimuths [deg] (the thruster's reach, as Table 1's).
CANDIDATE_THETA_DEG = (-80.0, -45.0, 0.0, 45.0, 80.0)
CANDIDATE_PSI_DEG = (-135.0, -90.0, -45.0, 0.0, 45.0, 90.0, 135.0, 180.0)


def random_sequence(rng, n_firings, impulse_n_s, window_s, max_thrust_n=TABLE1_MAX_THRUST_N,
                    position_body_m=TABLE1_THRUSTER_POSITION_BODY_M, first_s=1.0, ramp_levels=()):
    """n_firings firings of equal duration and impulse_n_s in all, their directions drawn from the candidate grid
    and their starts from a 0.5 s grid in [first_s, window_s - 5 s] (at least one firing length apart), all from
    rng: one candidate of the design search. The first len(ramp_levels) fire at those levels [%], the rest at
    full thrust: graded pulses keep the first responses inside the filter's linear range while the parameters
    are uncertain by percents (docs/post_capture.md)."""
    levels = [float(v) for v in ramp_levels] + [100.0] * (n_firings - len(ramp_levels))
    duration = impulse_n_s / (max_thrust_n * sum(levels) / 100.0)
    slots = np.arange(first_s, window_s - 5.0, max(0.5, math.ceil(duration / 0.5) * 0.5 + 0.5))
    starts = np.sort(rng.choice(slots, size=n_firings, replace=False))
    rows = [(float(t0), duration, level, float(rng.choice(CANDIDATE_THETA_DEG)), float(rng.choice(CANDIDATE_PSI_DEG)))
            for t0, level in zip(starts, levels, strict=True)]
    return firings_from_rows(rows, max_thrust_n, position_body_m)


class DesignResult(NamedTuple):
    """The chosen sequence and every candidate's figure of merit."""

    firings: tuple
    information_gain: float
    candidate_gains: tuple


def choose_sequence(case, config, prior, rng, candidates=16, n_firings=9, impulse_n_s=None, window_s=25.0,
                    ramp_levels=()):
    """The candidate sequence (``random_sequence``, graded by ramp_levels) of most information
    (``information_gain``) at Table 1's impulse (or impulse_n_s) over window_s seconds: a D-optimal choice by
    random search."""
    impulse = total_impulse_n_s(table1_firings()) if impulse_n_s is None else impulse_n_s
    best, gains = None, []
    for _ in range(candidates):
        firings = random_sequence(rng, n_firings, impulse, window_s, ramp_levels=ramp_levels)
        gain = information_gain(case, firings, window_s, config, prior)
        gains.append(gain)
        if best is None or gain > best[1]:
            best = (firings, gain)
    return DesignResult(best[0], best[1], tuple(gains))
