"""The plant from the capture on (package doc): welded where it is, or the arm's grasp, then the combined body or
the two bodies released (``Plant`` mixes it in)."""

import dataclasses
import math

import numpy as np

from flyby_msgs_py import event_payloads, events
from flyby_msgs_py.wire import Event
from flyby_sim.chaser_body import SixDofChaser
from flyby_sim.dynamics.actuators import plume_free_thrusters
from flyby_sim.dynamics.attitude import AttitudePropagator, body_point_state
from flyby_sim.dynamics.grasp import Body, Contact, simulate_grasp, weld
from flyby_sim.dynamics.orbital import q_eci_from_body, q_hill_from_body, quat_eci_from_hill, rk4_step_floats
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_multiply,
    quat_rotate,
    quat_to_matrix,
    rotation_vector_from_quat,
)


class CapturePhases:
    """Capture, grasp, lock, transport and release, on the state of ``Plant``."""

    @property
    def captured(self):
        """True once ``capture`` has grasped the target (or attached the chaser to it), or from the start when the
        run starts attached."""
        return self._mode != 'free'

    @property
    def mode(self):
        """'free'; after the capture 'attached' (no grasp configured), 'grasp', then 'combined' or 'released'."""
        return self._mode

    def capture(self):
        """The manipulator grasps the target where the chaser is now (seed 000 section 2.2 (4)-(5)).

        With a grasp configured (module doc) the arm's impedance takes over from the next step. Otherwise
        from the next step on the chaser keeps its current position in target_body axes and moves
        with the target (r_hill = C r_body, v_hill = C (omega_body x r_body) - Omega^H x r_hill); truth
        keeps flowing. Pending and later maneuvers are dropped (and commands until the arm locks). Idempotent.
        """
        if self.captured:
            return
        if self.config.grasp is not None:
            self._start_grasp()
            return
        self._mode = 'attached'
        c_hill_from_body = quat_to_matrix(self._last.q_hill_from_body)
        self._r_body_captured = c_hill_from_body.T @ np.array(self._y[:3])
        self._thrusters.cancel_all()
        if self._chaser is not None:
            self._chaser.cancel_all()
            self._q_target_from_chaser = quat_multiply(quat_conjugate(self._last.q_hill_from_body),
                                                       self._last.q_hill_from_chaser_body)
        self._events.append(Event(self.t, 'OK', events.CAPTURED, f'chaser attached to the target at t = {self.t:.3f} s',
                                  dict(t=self.t, r_hill=np.array(self._y[:3]), r_body=self._r_body_captured)))

    def _start_grasp(self):
        """The grasp from the first contact now: two free bodies joined by the arm, integrated at once (nothing
        commands them until the arm locks) in the inertial frame L whose axes are hill's now and whose origin is
        the target's CoM."""
        g = self.config.grasp
        last, chaser = self._last, self._chaser
        self._thrusters.cancel_all()
        chaser.cancel_all()
        self._mode = 'grasp'
        t0 = self.t
        self._q_eci_from_local = quat_eci_from_hill(t0, self.mean_motion_rad_s)
        r_c = np.array(self._y[:3])
        chaser_body = Body(self._mass_kg, np.array(self.config.chaser_body.inertia), r_c,
                           self._inertial_velocity(r_c, np.array(self._y[3:])), last.q_hill_from_chaser_body,
                           last.omega_chaser_body, chaser.wheels.axis_matrix @ chaser.h_wheels_n_m_s)
        target_body = Body(g.target_mass_kg, np.array(self.config.target_inertia), np.zeros(3), np.zeros(3),
                           last.q_hill_from_body, last.omega_body)
        contact = Contact.at_first_contact(g.impedance, chaser_body, target_body, g.grasp_point_body_m)
        result = simulate_grasp(chaser_body, target_body, g.impedance, contact.r_ee, g.grasp_point_body_m,
                                g.max_duration_s, q_target_from_handle=contact.q_t_h, output_step_s=self.config.step_s,
                                velocity_tolerance_mps=g.velocity_tolerance_mps,
                                rate_tolerance_rad_s=g.rate_tolerance_rad_s)
        self._contact = contact
        t_end = result.t_release_s if result.released else (
            result.damping_time_s if math.isfinite(result.damping_time_s) else float(result.t_s[-1]))
        self._grasp = (result, self._step_index, round(t_end / self.config.step_s))
        self._events.append(Event(t0, 'OK', events.CAPTURED, f'the manipulator grasps the target at t = {t0:.3f} s',
                                  dict(t=t0, r_hill=r_c, r_end_effector_body_m=contact.r_ee,
                                       position_error_m=float(np.linalg.norm(
                                           contact.wrench(chaser_body, target_body)[2])))))
        if self._grasp[2] == 0:  # beyond the arm's limits at the first contact
            self._end_grasp(result, 0)

    def _start_attached(self):
        """The run starts with the chaser holding the target as one rigid body (module doc): the chaser's initial
        state, the target's CoM at X_s in its axes turning with it, welded at t = 0 in the inertial frame that is
        hill now."""
        g, chaser, last = self.config.grasp, self._chaser, self._last
        self._q_eci_from_local = quat_eci_from_hill(self.t, self.mean_motion_rad_s)
        r_c = np.array(self._y[:3])
        v_c = self._inertial_velocity(r_c, np.array(self._y[3:]))
        c_hill_from_chaser = quat_to_matrix(last.q_hill_from_chaser_body)
        x_s_hill = c_hill_from_chaser @ np.asarray(g.attached_target_com_body_m)
        omega_hill = c_hill_from_chaser @ last.omega_chaser_body
        q_ct = np.asarray(g.q_chaser_from_target)
        chaser_body = Body(self._mass_kg, np.array(self.config.chaser_body.inertia), r_c, v_c,
                           last.q_hill_from_chaser_body, last.omega_chaser_body,
                           chaser.wheels.axis_matrix @ chaser.h_wheels_n_m_s)
        target_body = Body(g.target_mass_kg, np.array(self.config.target_inertia), r_c + x_s_hill,
                           v_c + np.cross(omega_hill, x_s_hill), quat_multiply(last.q_hill_from_chaser_body, q_ct),
                           quat_rotate(quat_conjugate(q_ct), last.omega_chaser_body))
        props = self._lock(chaser_body, target_body)
        self._events.append(Event(self.t, 'OK', events.ATTACHED,
                                  f'the run starts with the chaser holding the target: one rigid body of '
                                  f'{props.mass_kg:.2f} kg', dict(t=self.t)))
        self._combined_state()
        self._last = self._truth_rigid(self._body.totals, self._body)

    def start_transport(self):
        """TRANSPORT (seed 004 §2.3): from now on the combined body's wrench commands fire only the thrusters whose
        exhaust misses the target (``actuators.plume_free_thrusters`` about the true target CoM); returns their
        (N,) mask. Idempotent."""
        if self._mode != 'combined' or self.config.grasp.transport_plume_cone_deg is None:
            raise ValueError(f'start_transport: needs the combined body and a transport section, mode {self._mode!r}')
        if self._transport_mask is None:
            self._transport_mask = plume_free_thrusters(self._body.layout, self._x_s_body,
                                                        self.config.grasp.transport_plume_cone_deg)
            self._restrict()
            self._events.append(Event(self.t, 'OK', events.TRANSPORT_THRUSTERS,
                                      f'transport: thrusters {np.flatnonzero(~self._transport_mask).tolist()} '
                                      f'blocked (exhaust at the target)',
                                      dict(blocked=np.flatnonzero(~self._transport_mask))))
        return self._transport_mask

    def _inertial_velocity(self, r_hill, v_hill):
        """The velocity in L (hill axes at the capture) of a point at r_hill moving at v_hill relative to hill."""
        return v_hill + np.cross((0.0, -self.mean_motion_rad_s, 0.0), r_hill)  # Omega^H = [0, -n, 0] (eq 11)

    def _hill_of_local(self, t, body):
        """(r_hill, v_hill relative to hill, q_hill_from_body, q_eci_from_body) of a grasp Body in L at time t."""
        q_hill_from_local = q_hill_from_body(t, self.mean_motion_rad_s, self._q_eci_from_local)
        r = quat_rotate(q_hill_from_local, body.r_m)
        v = quat_rotate(q_hill_from_local, body.v_mps) - np.cross((0.0, -self.mean_motion_rad_s, 0.0), r)
        return r, v, quat_multiply(q_hill_from_local, body.q_inertial_from_body), quat_multiply(
            self._q_eci_from_local, body.q_inertial_from_body)

    def _step_grasp(self):
        self._step_index += 1
        result, k0, k_end = self._grasp
        k = self._step_index - k0
        t = self.t
        chaser_b, target_b = result.bodies_at(k)
        r, v, _, q_eci = self._hill_of_local(t, chaser_b)
        chaser = self._chaser
        chaser.set_attitude(q_eci, chaser_b.omega_body)
        chaser.set_translation(r.tolist() + v.tolist(), t)
        chaser.advance_idle()
        self._y = chaser.y_translation
        # The accelerometer feels the arm's pull: the chaser's delta-v in L over the step, in hill axes now.
        dv_local = chaser_b.v_mps - result.states[k - 1, 3:6]
        dv_hill = quat_rotate(q_hill_from_body(t, self.mean_motion_rad_s, self._q_eci_from_local), dv_local)
        for i in range(3):
            self._imu_dv_hill[i] += dv_hill[i]
        r_t, v_t, q_t, _ = self._hill_of_local(t, target_b)
        self._target_now = (q_t, target_b.omega_body, r_t, v_t)
        if k == k_end:
            self._end_grasp(result, k)
        return self._rigid_truth_and_samples(self._chaser)

    def _end_grasp(self, result, k):
        """The arm locks (one rigid body, ``weld``) or lets go (both fly freely) at grasp sample k."""
        t = self.t
        chaser_b, target_b = result.bodies_at(k)
        peaks = dict(peak_force_n=float(np.max(np.linalg.norm(result.force_n[:k + 1], axis=1))),
                     peak_torque_n_m=float(np.max(np.linalg.norm(result.torque_n_m[:k + 1], axis=1))))
        if result.released:
            self._mode = 'released'
            r_t, v_t, _, q_eci_t = self._hill_of_local(t, target_b)
            self._target_free = (AttitudePropagator(q_eci_t, target_b.omega_body, self.config.target_inertia, t0=t),
                                 r_t.tolist() + v_t.tolist())
            self._events.append(Event(t, 'WARN', events.GRASP_RELEASED, f'the arm lets go at t = {t:.3f} s: '
                                                                    f'{result.release_reason}',
                                      dict(t=t, reason=result.release_reason, **peaks)))
            return
        props = self._lock(chaser_b, target_b)
        displacement, rotation = self._arm_deflection(result.bodies_at(0), (chaser_b, target_b))
        self._events.append(Event(t, 'OK', events.GRASP_DAMPED, f'the arm locks at t = {t:.3f} s: one rigid body of '
                                                            f'{props.mass_kg:.2f} kg',
                                  event_payloads.encode(event_payloads.GraspDamped(
                                      t, float(result.t_s[k]), displacement, rotation), peaks)))

    def _lock(self, chaser_b, target_b):
        """Chaser and target (grasp Bodies in the local inertial frame) one rigid body from now on (``weld``): the
        combined body integrated from here, its thrusters at their true positions about the combined CoM; returns
        its CombinedMassProperties."""
        t = self.t
        props, state = weld(chaser_b, target_b)
        c_local_from_chaser = quat_to_matrix(chaser_b.q_inertial_from_body)
        self._x_s_body = c_local_from_chaser.T @ (target_b.r_m - chaser_b.r_m)  # X_s, seed 004
        self._q_chaser_from_target = quat_multiply(quat_conjugate(chaser_b.q_inertial_from_body),
                                                   target_b.q_inertial_from_body)
        self._com_body = props.com_body_m
        chaser, cfg = self._chaser, self.config
        body_cfg = dataclasses.replace(cfg.chaser_body, inertia=tuple(map(tuple, props.inertia_body_kg_m2.tolist())),
                                       wheel_momentum0_n_m_s=tuple(chaser.h_wheels_n_m_s.tolist()))
        r, v, _, q_eci = self._hill_of_local(t, Body(props.mass_kg, props.inertia_body_kg_m2, state.r_m, state.v_mps,
                                                     state.q_inertial_from_body, state.omega_body))
        combined = SixDofChaser(body_cfg, cfg.thrusters, tuple(r), tuple(v), props.mass_kg, self.mean_motion_rad_s,
                                self._accel, cfg.step_s, 0.0, None, self._events_append, errors=chaser.errors,
                                com_body_m=props.com_body_m)
        combined.set_attitude(q_eci, state.omega_body)
        combined.set_translation(r.tolist() + v.tolist(), t)
        combined.set_health(self._body.health)  # injected faults stay with the hardware, closed valves too
        self._body = combined
        if self._isolated:
            self._restrict()
        self._mode = 'combined'
        self._t_locked = t
        self._dv_before_lock = self._dv_total_mps
        self._imu_omega_last = None
        return props

    def _arm_deflection(self, contact_bodies, locked_bodies):
        """How far the arm's compliance moved the grasp handle from the first contact to the lock, in the chaser's
        axes: (displacement [m], rotation vector [rad]), what the arm's joint encoders read (exactly, here)."""
        poses = []
        for chaser_b, target_b in (contact_bodies, locked_bodies):
            q_chaser_from_target = quat_multiply(quat_conjugate(chaser_b.q_inertial_from_body),
                                                 target_b.q_inertial_from_body)
            p_handle = target_b.r_m + quat_rotate(target_b.q_inertial_from_body, self._contact.r_g) - chaser_b.r_m
            poses.append((quat_rotate(quat_conjugate(chaser_b.q_inertial_from_body), p_handle),
                          quat_multiply(q_chaser_from_target, self._contact.q_t_h)))
        (p0, q0), (p1, q1) = poses
        return p1 - p0, rotation_vector_from_quat(quat_multiply(q1, quat_conjugate(q0)))

    def _step_combined(self):
        body = self._body
        self._step_index += 1
        body.advance(self.t - self.config.step_s, self.t)
        dv = body.totals.dv_thrust_hill
        for k in range(3):
            self._imu_dv_hill[k] += dv[k]
        self._combined_state()
        return self._rigid_truth_and_samples(body)

    def _combined_state(self):
        """The chaser's and the target's state from the combined body's now."""
        body = self._body
        y = body.y_translation
        self._mass_kg = body.mass_kg - self.config.grasp.target_mass_kg
        self._dv_total_mps = self._dv_before_lock + body.dv_total_mps
        q_hill = body.q_hill_from_body(self.t)
        c_hill = quat_to_matrix(q_hill)
        omega = body.omega_body
        n = self.mean_motion_rad_s
        r_c, v_c = body_point_state(c_hill, omega, -self._com_body, n)  # eq 8-9 of the chaser's CoM ...
        r_t, v_t = body_point_state(c_hill, omega, self._x_s_body - self._com_body, n)  # ... and the target's
        self._y = (np.array(y[:3]) + r_c).tolist() + (np.array(y[3:]) + v_c).tolist()
        q_t = quat_multiply(q_hill, self._q_chaser_from_target)
        self._target_now = (q_t, quat_rotate(quat_conjugate(self._q_chaser_from_target), omega),
                            np.array(y[:3]) + r_t, np.array(y[3:]) + v_t)

    def _step_released(self):
        self._step_index += 1
        attitude, y_t = self._target_free
        t = self.t
        y_t = rk4_step_floats(self._coast_rhs, t - self.config.step_s, y_t, self.config.step_s)
        q_eci, omega = attitude.state_at(t)
        self._target_free = (attitude, y_t)
        self._target_now = (q_hill_from_body(t, self.mean_motion_rad_s, q_eci), omega, np.array(y_t[:3]),
                            np.array(y_t[3:]))
        chaser = self._chaser
        chaser.advance(t - self.config.step_s, t)
        self._y = chaser.y_translation
        self._mass_kg = chaser.mass_kg
        return self._rigid_truth_and_samples(chaser)


    def _step_attached(self):
        self._step_index += 1
        q_hill_from_body, omega_body = self._target_attitude()
        r_hill, v_hill = body_point_state(quat_to_matrix(q_hill_from_body), omega_body, self._r_body_captured,
                                          self.mean_motion_rad_s)  # eq 8-9 of a body-fixed point
        self._y = r_hill.tolist() + v_hill.tolist()
        if self._chaser is not None:  # the chaser turns with the target; its wheels keep their momentum
            chaser = self._chaser
            q_hill_from_chaser = quat_multiply(q_hill_from_body, self._q_target_from_chaser)
            chaser.set_attitude(q_eci_from_body(self.t, self.mean_motion_rad_s, q_hill_from_chaser),
                                quat_rotate(quat_conjugate(self._q_target_from_chaser), omega_body))
            chaser.set_translation(self._y, self.t)
            chaser.advance_idle()
            return self._rigid_truth_and_samples(chaser)
        self._last = self._truth(np.zeros(3), False)
        self._sample(self._last)
        return self._last
