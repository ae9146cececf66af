"""Seed 001's quantities (Seweryn and Banaszkiewicz, section 3) of a run of the synchronized approach, from the truth
and the estimate: the windows of its stages, the Euler angles R = Rz(psi) Ry(theta) Rx(phi) as the scenario reads
rpy_rad and their estimation errors (Fig 5), the chaser's motion relative to the target (Fig 4), both bodies'
attitude and their relative one (Fig 6), the kinetic energies (Fig 7)."""

from __future__ import annotations

import typing

import numpy as np
from scipy.spatial.transform import Rotation

from flyby_mission.report.analysis import matched_pairs, sigma3
from flyby_mission.report.loading import Skipped, match_stamps, velocity_hill
from flyby_msgs_py import contract as c
from flyby_msgs_py.wire import STAMP_TOLERANCE_S
from flyby_sim.dynamics.attitude import kinetic_energy
from flyby_sim.dynamics.rigid_body import ReactionWheels
from flyby_sim.dynamics.rotation import quat_conjugate, quat_multiply, quat_rotate_many, rotation_angle_many

SYNC_STAGES = (('stages 1-2', (c.PHASE_SYNC_APPROACH, c.PHASE_ATTITUDE_SYNC)),
               ('stages 3-4', (c.PHASE_ORBITING, c.PHASE_DOCKING)))


def stage_windows(phases):
    """{'stages 1-2': (t0, t1), 'stages 3-4': (t0, t1)} [s] of the phase windows [(phase, t0, t1)]: seed 001's
    stages 1-2 (phase-space transfer, attitude synchronization) and 3-4 (orbiting, docking), each from the start of
    its first phase to the end of its last; a pair the run did not reach is left out."""
    out = {}
    for name, members in SYNC_STAGES:
        spans = [(t0, t1) for phase, t0, t1 in phases if phase in members]
        if spans:
            out[name] = (min(t0 for t0, _ in spans), max(t1 for _, t1 in spans))
    return out


def euler_rpy(q_hill_from_body):
    """Euler angles (phi, theta, psi) [rad] (N, 3) of q_hill_from_body (N, 4): R = Rz(psi) Ry(theta) Rx(phi), the
    scenario's reading of rpy_rad (scipy's extrinsic 'xyz'); theta in [-pi/2, pi/2], phi and psi in [-pi, pi]."""
    return Rotation.from_quat(q_hill_from_body).as_euler('xyz')


def euler_from_hill_rotation(rpy):
    """(N, 3, 3) J = d(phi, theta, psi) / d(dtheta_hill) at the Euler angles rpy (N, 3) [rad] (euler_rpy): a small
    rotation dtheta_hill about hill axes (q' = exp(dtheta_hill) q, how the estimator's attitude error is defined)
    moves the angles by J dtheta_hill. J inverts [Rz(psi) Ry(theta) e_x, Rz(psi) e_y, e_z], the hill-axes angular
    velocities of unit Euler rates, and grows without bound at theta = +-90 deg (gimbal lock)."""
    _, theta, psi = np.moveaxis(np.asarray(rpy, dtype=float), -1, 0)
    cos_psi, sin_psi, zero = np.cos(psi), np.sin(psi), np.zeros_like(psi)
    return np.stack((np.stack((cos_psi, sin_psi, zero), -1) / np.cos(theta)[:, None],
                     np.stack((-sin_psi, cos_psi, zero), -1),
                     np.stack((cos_psi * np.tan(theta), sin_psi * np.tan(theta), zero + 1.0), -1)), axis=1)


def euler_estimation_errors(run):
    """Seed 001 Fig 5: (t [s], error (N, 3), sigma (N, 3)) [rad] of the target's Euler angles (euler_rpy) estimated
    on /estimation/target/odom against the truth at the same stamps. sigma is the standard deviation the estimator
    publishes: its attitude covariance P (about hill axes, as estimation_errors reads it) carried into the angles to
    first order, J P J' with J = euler_from_hill_rotation at the truth."""
    matched = matched_pairs(run, c.EST_TARGET_ODOM, c.SIM_TARGET_ODOM)
    if isinstance(matched, str):
        raise Skipped(matched)
    e, tr, i, j = matched
    rpy_true = euler_rpy(tr.orientation_xyzw[j])
    error = (euler_rpy(e.orientation_xyzw[i]) - rpy_true + np.pi) % (2.0 * np.pi) - np.pi  # the short way round
    jac = euler_from_hill_rotation(rpy_true)
    covariance = jac @ e.pose_covariance[i, 3:, 3:] @ np.swapaxes(jac, 1, 2)
    return e.t[i], error, sigma3(covariance, slice(0, 3)) / 3.0


class SyncTranslation(typing.NamedTuple):
    """Seed 001 Fig 4 (sync_translation)."""

    t: np.ndarray              # (N,) [s] truth stamps of chaser and target
    r_hill: np.ndarray         # (N, 3) [m] chaser CoM from the target's (the hill origin)
    v_hill: np.ndarray         # (N, 3) [m/s] relative to the rotating hill frame, hill axes
    r_target_body: np.ndarray  # (N, 3) [m] r_hill in target_body axes
    a_thrust_mps2: np.ndarray  # (N,) |thrust force| / initial mass, NaN where /sim/chaser/thrust has no sample


def sync_translation(run):
    """Seed 001 Fig 4 from the truth: the chaser's position and velocity relative to the target in hill (the twist is
    in chaser_body axes: velocity_hill), its position in target_body axes (constant while orbiting, seed 001 Fig 2;
    radial while docking, Fig 3), and the thrusters' acceleration |F| / m0 with the scenario's initial mass (the fuel
    burned, under 3 % of it in seweryn_tumbling, left out)."""
    truth, target, i_c, i_t = run.truth_pair()
    t, r_hill = truth.t[i_c], truth.position[i_c]
    r_target_body = quat_rotate_many(quat_conjugate(target.orientation_xyzw[i_t].T).T, r_hill)
    a_thrust = np.full(len(t), np.nan)
    thrust = run.get(c.SIM_CHASER_THRUST)
    if thrust is not None:
        i_a, i_f = match_stamps(t, thrust.t)
        a_thrust[i_a] = np.linalg.norm(thrust.force[i_f], axis=1) / run.need_scenario().chaser.mass_kg
    return SyncTranslation(t, r_hill, velocity_hill(truth)[i_c], r_target_body, a_thrust)


def relative_attitude(q_hill_from_chaser, omega_chaser_body, q_hill_from_target, omega_target_body):
    """(q_target_from_chaser (N, 4), omega_relative_body (N, 3) [rad/s]) of the two bodies' truth (N, 4) and (N, 3):
    the chaser's attitude in target_body and its angular velocity relative to the target's, omega_chaser -
    C_chaser_from_target omega_target in chaser_body axes; synchronized (seed 001 stages 3-4) the one is constant
    and the other zero."""
    q_target_from_chaser = quat_multiply(quat_conjugate(np.asarray(q_hill_from_target).T),
                                         np.asarray(q_hill_from_chaser).T).T
    omega_target_chaser_axes = quat_rotate_many(quat_conjugate(q_target_from_chaser.T).T, omega_target_body)
    return q_target_from_chaser, np.asarray(omega_chaser_body) - omega_target_chaser_axes


class SyncAttitude(typing.NamedTuple):
    """Seed 001 Fig 6 (sync_attitude); the last four are None when stage 3 did not start."""

    t: np.ndarray                          # (N,) [s] truth stamps of both bodies
    rpy_chaser: np.ndarray                 # (N, 3) [rad] chaser_body in hill (euler_rpy)
    rpy_target: np.ndarray                 # (N, 3) [rad] target_body in hill
    omega_chaser_body: np.ndarray          # (N, 3) [rad/s] inertial, chaser_body axes
    omega_target_body: np.ndarray          # (N, 3) [rad/s] inertial, target_body axes
    relative_angle_rad: np.ndarray         # (N,) rotation angle of q_target_from_chaser
    omega_relative_body: np.ndarray        # (N, 3) [rad/s] relative_attitude's
    t_stage3: float | None                 # [s] the first stamp of stage 3 (ORBITING)
    rpy_carried: np.ndarray | None         # (N, 3) [rad] the target's attitude times its stage-3 relative one
    omega_carried_body: np.ndarray | None  # (N, 3) [rad/s] omega_target in the chaser axes of that attitude
    drift_rad: np.ndarray | None           # (N,) angle of the relative attitude from its value at t_stage3


def sync_attitude(run):
    """Seed 001 Fig 6 from the truth: both bodies' Euler angles (euler_rpy) and body rates, their relative attitude,
    and from the start of stage 3 the target's motion carried into the chaser by the relative attitude of that
    instant (where the chaser is if it turns with the target: in stages 3-4 the chaser's own, up to the drift,
    as summary.json's relative_attitude_drift_max_deg measures it to the grasp)."""
    chaser, target, i_c, i_t = run.truth_pair()
    t = chaser.t[i_c]
    q_c, w_c = chaser.orientation_xyzw[i_c], chaser.angular[i_c]
    q_t, w_t = target.orientation_xyzw[i_t], target.angular[i_t]
    q_rel, w_rel = relative_attitude(q_c, w_c, q_t, w_t)
    starts = [t0 for phase, t0, _ in run.phases if phase == c.PHASE_ORBITING]
    carried = (None, None, None, None)
    k = int(np.searchsorted(t, starts[0] - STAMP_TOLERANCE_S)) if starts else len(t)
    if k < len(t):
        q_rel0 = np.tile(q_rel[k], (len(t), 1))
        carried = (float(t[k]), euler_rpy(quat_multiply(q_t.T, q_rel0.T).T),
                   quat_rotate_many(quat_conjugate(q_rel[k]), w_t),
                   rotation_angle_many(quat_multiply(quat_conjugate(q_rel0.T), q_rel.T).T))
    return SyncAttitude(t, euler_rpy(q_c), euler_rpy(q_t), w_c, w_t, rotation_angle_many(q_rel), w_rel, *carried)


def wheel_energy_j(wheels, speed_rad_s, omega_body):
    """Spin kinetic energy [J] (N,) of the reaction wheels (flyby_sim.dynamics.rigid_body.ReactionWheels) at their
    speeds relative to the body (N, K) [rad/s] (/sim/chaser/wheels) and the body rate omega_body (N, 3): the sum of
    h^2 / (2 J_s) with h = J_s (speed + a . omega) each wheel's absolute momentum. The chaser's inertia leaves the
    wheels' spin-axis inertia out, so this adds to its body's 1/2 omega . I omega."""
    spin_rad_s = np.asarray(speed_rad_s) + np.asarray(omega_body) @ wheels.axes_body.T
    return 0.5 * np.sum(wheels.spin_inertia_kg_m2 * spin_rad_s ** 2, axis=1)


class SyncEnergy(typing.NamedTuple):
    """Seed 001 Fig 7 (kinetic_energies) [J]."""

    t: np.ndarray                      # (N,) [s] truth stamps of both bodies
    chaser_translational: np.ndarray   # (N,) 1/2 m |v_hill|^2, relative to the target (the hill frame)
    chaser_rotational: np.ndarray      # (N,) 1/2 omega . I omega of the chaser's body
    chaser_wheels: np.ndarray          # (N,) wheel_energy_j, NaN where /sim/chaser/wheels has no sample
    target_translational: np.ndarray   # (N,) 1/2 M |v_hill|^2 (zero: the hill origin is the target's CoM)
    target_rotational: np.ndarray      # (N,) 1/2 omega . I omega (constant: torque-free)


def kinetic_energies(run):
    """Seed 001 Fig 7 from the truth and the scenario's masses and inertias: each body's translational and rotational
    kinetic energy. Translation is relative to the target's centre of mass in the rotating hill frame, as the
    paper's relative motion (its eq 2) and Fig 4 have it: the velocity of velocity_hill, not the orbital one
    (1/2 m (7.8 km/s)^2 would hide every change); the chaser's mass is the initial one (its fuel burned left out),
    its inertia that of its body, the reaction wheels' spin energy apart (wheel_energy_j)."""
    scenario = run.need_scenario()
    chaser, target, i_c, i_t = run.truth_pair()
    t, w_c, w_t = chaser.t[i_c], chaser.angular[i_c], target.angular[i_t]
    wheels_j = np.full(len(t), np.nan)
    wheels = run.get(c.SIM_CHASER_WHEELS)
    if wheels is not None:
        config = scenario.chaser.wheels
        i_w, i_s = match_stamps(t, wheels.t)
        assembly = ReactionWheels(config.axes, config.max_torque_n_m, config.max_momentum_n_m_s,
                                  config.spin_inertia_kg_m2)
        wheels_j[i_w] = wheel_energy_j(assembly, wheels.velocity[i_s], w_c[i_w])
    return SyncEnergy(
        t,
        0.5 * scenario.chaser.mass_kg * np.sum(velocity_hill(chaser)[i_c] ** 2, axis=1),
        np.array([kinetic_energy(w, scenario.chaser_inertia) for w in w_c]),
        wheels_j,
        0.5 * scenario.target.mass_kg * np.sum(velocity_hill(target)[i_t] ** 2, axis=1),
        np.array([kinetic_energy(w, scenario.target_inertia) for w in w_t]))
