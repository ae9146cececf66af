"""Grasp control (seed 000 §2.2 phase (5)): the manipulator as an impedance between the chaser's end effector and
the target's grasp point, from the first contact until the relative motion is damped (or the grasp lets go).

Seed 000 names the phase only ("the manipulator keeps the relative position and velocity and manages force and
torque caused by mechanical contact"); the model is ours. Both bodies are rigid and free (the orbit left out over
the seconds of the grasp); a body may carry reaction wheels whose axial momentum is held (no motor torque: a
gyrostat). The end effector is a frame fixed in the chaser (its point r_ee from the chaser CoM), the grasp handle
a frame fixed in the target (its point r_g from the target CoM); at the first contact the handle frame is where
the end effector frame is, less the residual capture errors (``first_contact``: the arm reaches along chaser_body
+x, DESIGN §3, to the grasp point's distance; the residual error off that line is the spring's first deflection).
The arm pulls the handle toward the end effector with a six-axis spring and damper (inertial axes):

.. math::

    F = -K_p \\delta x - D_p \\delta v, \\qquad \\tau = -K_r e - D_r (\\omega_t - \\omega_c)

with dx = p_g - p_ee, dv the grasp point's velocity relative to the chaser-fixed point where it is
(v_g - v_c - omega_c x (p_g - r_c)), e the rotation vector of q_inertial_from_handle * q_inertial_from_ee^-1.
F and tau act on the target at the grasp point; -F (at the same point) and -tau act on the chaser through the arm, so
the contact is internal: total linear and angular momentum are kept exactly, and the impedance only dissipates:
the springs' energy 1/2 K_p dx^2 + 1/2 K_r e^2 is exact (e . de/dt = e . (omega_t - omega_c), a rotation leaving
its own axis fixed), and the bodies lose D_p |dv|^2 + D_r |omega_t - omega_c|^2 >= 0.
Quaternions (x, y, z, w), ``q_inertial_from_body``.

The arm's limits: when |F| or |tau| would exceed what the arm holds (``max_force_n``, ``max_torque_n_m``), or
the handle leaves the arm's compliance stroke (``max_stroke_m``), the gripper lets go (``released``) and both
bodies fly on freely. Otherwise the grasp is damped once the relative velocity and rate stay below their
tolerances (``damping_time_s``), and ``weld`` makes the two one rigid body with the momentum they carry.
"""

import dataclasses
import math
from typing import NamedTuple

import numpy as np
from scipy.integrate import solve_ivp

from flyby_msgs_py import params
from flyby_sim.dynamics.attitude import euler_rate, quaternion_rate, validated_inertia
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.combined_body import CombinedState, combined_mass_properties
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_multiply,
    quat_normalize,
    quat_rotate,
    quat_to_matrix,
    rotation_vector_from_quat,
)


@params.record
class Impedance:
    """The arm's impedance and limits (scenario post_capture.grasp, flyby_msgs_py.params; validated, ValueError names
    the field)."""

    stiffness_n_m: float = params.key('post_capture.grasp.stiffness_n_per_m')
    damping_n_s_m: float = params.key('post_capture.grasp.damping_n_s_per_m')
    rot_stiffness_n_m_rad: float = params.key('post_capture.grasp.rot_stiffness_n_m_per_rad')
    rot_damping_n_m_s_rad: float = params.key('post_capture.grasp.rot_damping_n_m_s_per_rad')
    max_force_n: float = params.key('post_capture.grasp.max_force_n')
    max_torque_n_m: float = params.key('post_capture.grasp.max_torque_n_m')
    max_stroke_m: float = params.key('post_capture.grasp.max_stroke_m')

    def __post_init__(self):
        for f in dataclasses.fields(self):
            require_positive(f.name, getattr(self, f.name))


class Body(NamedTuple):
    """One rigid body's mass properties and state (inertial frame; omega in body axes), and the momentum its
    reaction wheels hold, body axes (constant: no motor torque)."""

    mass_kg: float
    inertia_body_kg_m2: np.ndarray
    r_m: np.ndarray
    v_mps: np.ndarray
    q_inertial_from_body: np.ndarray
    omega_body: np.ndarray
    h_wheels_body_n_m_s: tuple = (0.0, 0.0, 0.0)


class GraspResult(NamedTuple):
    """What the grasp did (module doc); the histories at every output sample."""

    t_s: np.ndarray
    chaser: Body  # at the end
    target: Body
    force_n: np.ndarray  # (N, 3) on the target, inertial
    torque_n_m: np.ndarray  # (N, 3)
    peak_force_n: float
    peak_torque_n_m: float
    released: bool
    t_release_s: float  # nan unless released
    release_reason: str
    damping_time_s: float  # nan unless damped within the duration
    dissipated_j: np.ndarray  # (N,) energy the dampers took since the contact
    energy_j: np.ndarray  # (N,) kinetic energy of both bodies plus the springs' energy
    states: np.ndarray  # (N, 26) chaser then target: r, v, q_inertial_from_body, omega_body (``bodies_at``)

    def bodies_at(self, k):
        """(chaser, target) Bodies at output sample k."""
        return _unpack(self.states[k], self.chaser, self.target)


def _unpack(y, chaser, target):
    def body(y6, b):
        return b._replace(r_m=y6[0:3], v_mps=y6[3:6], q_inertial_from_body=y6[6:10], omega_body=y6[10:13])
    return body(y[0:13], chaser), body(y[13:26], target)


def _pack(chaser, target):
    return np.concatenate([np.concatenate((b.r_m, b.v_mps, quat_normalize(b.q_inertial_from_body), b.omega_body))
                           for b in (chaser, target)])


def first_contact(chaser, target, r_grasp_target_m):
    """The end effector's point [m] in chaser_body at the first contact: on +x, the direction the arm reaches
    (DESIGN §3), at the grasp point's distance from the chaser CoM (module doc)."""
    p_g = target.r_m + quat_rotate(target.q_inertial_from_body, np.asarray(r_grasp_target_m, dtype=float))
    return np.array([float(np.linalg.norm(p_g - chaser.r_m)), 0.0, 0.0])


class Contact:
    """The arm's impedance between the end effector (r_ee, q_chaser_from_ee in the chaser) and the grasp handle
    (r_g, q_target_from_handle in the target): ``wrench`` of two bodies' states (module doc)."""

    def __init__(self, impedance, r_ee_chaser_m, q_chaser_from_ee, r_grasp_target_m, q_target_from_handle):
        self.k = impedance
        self.r_ee = np.asarray(r_ee_chaser_m, dtype=float)
        self.q_c_ee = quat_normalize(q_chaser_from_ee)
        self.r_g = np.asarray(r_grasp_target_m, dtype=float)
        self.q_t_h = quat_normalize(q_target_from_handle)

    @classmethod
    def at_first_contact(cls, impedance, chaser, target, r_grasp_target_m, q_chaser_from_ee=(0.0, 0.0, 0.0, 1.0)):
        """The contact of a grasp starting from these states: ``first_contact``'s end effector, the handle frame
        aligned with it (no attitude error; the rate mismatch still loads the wrist)."""
        q_ee0 = quat_multiply(chaser.q_inertial_from_body, quat_normalize(q_chaser_from_ee))
        return cls(impedance, first_contact(chaser, target, r_grasp_target_m), q_chaser_from_ee, r_grasp_target_m,
                   quat_multiply(quat_conjugate(target.q_inertial_from_body), q_ee0))

    def wrench(self, c, t):
        """(F, tau on the target, inertial; dx; e; arms from each CoM to the grasp point; relative velocities)."""
        arm_c = quat_rotate(c.q_inertial_from_body, self.r_ee)
        arm_t = quat_rotate(t.q_inertial_from_body, self.r_g)
        w_c = quat_rotate(c.q_inertial_from_body, c.omega_body)
        w_t = quat_rotate(t.q_inertial_from_body, t.omega_body)
        dx = (t.r_m + arm_t) - (c.r_m + arm_c)
        # The grasp point's velocity relative to the chaser-fixed point where it is now (not the end effector):
        # with it the force's power is exactly -d/dt(1/2 K dx^2) - D dv^2.
        dv = (t.v_mps + np.cross(w_t, arm_t)) - (c.v_mps + np.cross(w_c, arm_c + dx))
        q_ee = quat_multiply(c.q_inertial_from_body, self.q_c_ee)
        q_h = quat_multiply(t.q_inertial_from_body, self.q_t_h)
        e = rotation_vector_from_quat(quat_multiply(q_h, quat_conjugate(q_ee)))
        dw = w_t - w_c
        force = -self.k.stiffness_n_m * dx - self.k.damping_n_s_m * dv
        torque = -self.k.rot_stiffness_n_m_rad * e - self.k.rot_damping_n_m_s_rad * dw
        return force, torque, dx, e, dv, dw, arm_c + dx, arm_t

    def power_dissipated(self, dv, dw):
        return self.k.damping_n_s_m * float(dv @ dv) + self.k.rot_damping_n_m_s_rad * float(dw @ dw)

    def spring_energy(self, dx, e):
        return 0.5 * self.k.stiffness_n_m * float(dx @ dx) + 0.5 * self.k.rot_stiffness_n_m_rad * float(e @ e)


def _body_rates(b, force, torque_about_com, i_inv):
    """d/dt (r, v, q, omega) of a free body under a force and a torque about its CoM (inertial axes), its wheels'
    momentum h held: I omega_dot = T - omega x (I omega + h)."""
    torque_body = (quat_rotate(quat_conjugate(b.q_inertial_from_body), torque_about_com)
                   - np.cross(b.omega_body, b.h_wheels_body_n_m_s))
    w_dot = euler_rate(b.omega_body.tolist(), b.inertia_body_kg_m2.tolist(), i_inv.tolist(), torque_body.tolist())
    return np.concatenate((b.v_mps, force / b.mass_kg, quaternion_rate(b.q_inertial_from_body.tolist(),
                                                                        b.omega_body.tolist()), w_dot))


def kinetic_energy(b):
    """Translational plus rotational kinetic energy of a body [J] (its wheels' held momentum left out: the
    gyroscopic torque omega x h does no work on it)."""
    return 0.5 * b.mass_kg * float(b.v_mps @ b.v_mps) + 0.5 * float(b.omega_body @ b.inertia_body_kg_m2 @ b.omega_body)


def momentum(bodies):
    """(Total linear momentum [N s], total angular momentum about the inertial origin [N m s], wheels included) of
    free bodies."""
    p = sum(b.mass_kg * b.v_mps for b in bodies)
    h = sum(np.cross(b.r_m, b.mass_kg * b.v_mps)
            + quat_rotate(b.q_inertial_from_body, b.inertia_body_kg_m2 @ b.omega_body + b.h_wheels_body_n_m_s)
            for b in bodies)
    return p, h


def simulate_grasp(chaser, target, impedance, r_ee_chaser_m, r_grasp_target_m, duration_s,
                   q_chaser_from_ee=(0.0, 0.0, 0.0, 1.0), q_target_from_handle=None, output_step_s=0.01,
                   velocity_tolerance_mps=1e-3, rate_tolerance_rad_s=1e-3):
    """The grasp from the first contact at t = 0 (module doc) for duration_s [s].

    q_target_from_handle: the handle frame in the target; None: aligned with the end effector at contact (no
    attitude error; the rate mismatch still loads the wrist). Integrated by DOP853 (rtol 1e-10); the arm's limits
    are checked at every output sample (output_step_s apart).
    """
    require_positive('duration_s', duration_s)
    i_inv_c = np.linalg.inv(validated_inertia(chaser.inertia_body_kg_m2))
    i_inv_t = np.linalg.inv(validated_inertia(target.inertia_body_kg_m2))
    if q_target_from_handle is None:
        q_ee0 = quat_multiply(chaser.q_inertial_from_body, quat_normalize(q_chaser_from_ee))
        q_target_from_handle = quat_multiply(quat_conjugate(target.q_inertial_from_body), q_ee0)
    contact = Contact(impedance, r_ee_chaser_m, q_chaser_from_ee, r_grasp_target_m, q_target_from_handle)

    def rhs(_t, y):
        c, t = _unpack(y, chaser, target)
        force, torque, dx, e, dv, dw, arm_c_g, arm_t_g = contact.wrench(c, t)
        # F at the grasp point on the target, -F at the same point on the chaser (through the arm).
        yc = _body_rates(c, -force, np.cross(arm_c_g, -force) - torque, i_inv_c)
        yt = _body_rates(t, force, np.cross(arm_t_g, force) + torque, i_inv_t)
        return np.concatenate((yc, yt, [contact.power_dissipated(dv, dw)]))

    t_out = np.arange(0.0, duration_s + 0.5 * output_step_s, output_step_s)
    y0 = np.concatenate((_pack(chaser, target), [0.0]))
    sol = solve_ivp(rhs, (0.0, float(t_out[-1])), y0, method='DOP853', t_eval=t_out, rtol=1e-10, atol=1e-12)
    if sol.status != 0:
        raise RuntimeError(f'grasp integration failed: {sol.message}')
    n = sol.t.size
    forces, torques = np.empty((n, 3)), np.empty((n, 3))
    energy = np.empty(n)
    released, reason, t_release, t_damped = False, '', math.nan, math.nan
    k = impedance
    last = n - 1
    for i in range(n):
        c, t = _unpack(sol.y[:26, i], chaser, target)
        force, torque, dx, e, dv, dw, _, _ = contact.wrench(c, t)
        forces[i], torques[i] = force, torque
        energy[i] = kinetic_energy(c) + kinetic_energy(t) + contact.spring_energy(dx, e)
        over = [f'|F| {np.linalg.norm(force):.4g} N > {k.max_force_n} N' if np.linalg.norm(force) > k.max_force_n
                else '',
                f'|tau| {np.linalg.norm(torque):.4g} N m > {k.max_torque_n_m} N m'
                if np.linalg.norm(torque) > k.max_torque_n_m else '',
                f'stroke {np.linalg.norm(dx):.4g} m > {k.max_stroke_m} m' if np.linalg.norm(dx) > k.max_stroke_m
                else '']
        if any(over):
            released, reason, t_release, last = True, '; '.join(s for s in over if s), float(sol.t[i]), i
            break
        calm = np.linalg.norm(dv) < velocity_tolerance_mps and np.linalg.norm(dw) < rate_tolerance_rad_s
        if calm and math.isnan(t_damped):
            t_damped = float(sol.t[i])
        elif not calm:
            t_damped = math.nan
    c, t = _unpack(sol.y[:26, last], chaser, target)
    if released:  # after the release the bodies fly freely: the state at the release is handed on
        forces, torques, energy = forces[:last + 1], torques[:last + 1], energy[:last + 1]
    return GraspResult(sol.t[:last + 1], c, t, forces, torques, float(np.max(np.linalg.norm(forces, axis=1))),
                       float(np.max(np.linalg.norm(torques, axis=1))), released, t_release, reason,
                       math.nan if released else t_damped, sol.y[26, :last + 1], energy, sol.y[:26, :last + 1].T)


def weld(chaser, target):
    """The two bodies made one rigid body at their current states, keeping total linear and angular momentum (the
    chaser's wheels keep theirs): (CombinedMassProperties in chaser_body axes, CombinedState of the combined CoM)."""
    c_ib = quat_to_matrix(chaser.q_inertial_from_body)
    c_it = quat_to_matrix(target.q_inertial_from_body)
    x_s_body = c_ib.T @ (target.r_m - chaser.r_m)
    i_t_body = c_ib.T @ c_it @ target.inertia_body_kg_m2 @ c_it.T @ c_ib
    i_t_body = 0.5 * (i_t_body + i_t_body.T)
    props = combined_mass_properties(chaser.mass_kg, chaser.inertia_body_kg_m2, target.mass_kg, x_s_body, i_t_body)
    r = chaser.r_m + c_ib @ props.com_body_m
    p, h_origin = momentum((chaser, target))
    v = p / props.mass_kg
    h_com = h_origin - np.cross(r, props.mass_kg * v)
    omega_body = np.linalg.solve(props.inertia_body_kg_m2, c_ib.T @ h_com - np.asarray(chaser.h_wheels_body_n_m_s))
    return props, CombinedState(r, v, chaser.q_inertial_from_body.copy(), omega_body)
