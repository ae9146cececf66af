"""What the estimator node does, without ROS: both filters fed with the measurements and commands,
and the estimates and events they give (seed 000 §2.2 (1)).

Each vision attitude updates the target filter and gives a ``TargetEstimate``, then the convergence
of the target estimate (with, at the first, the batch maximum-likelihood check of the filter,
``batch``) and, once converged, its motion category (seed 000 §2.1) every CLASSIFY_PERIOD_S; each
relative position updates the navigation filter and gives a ``ChaserEstimate``; each commanded
maneuver becomes a known input of the navigation filter. With the six-degree-of-freedom chaser
(``chaser.model: rigid_body``) the chaser's own attitude filter (``chaser_attitude_filter``) takes each
IMU sample, and the ``ChaserEstimate`` is given at the IMU's stamps instead, with the attitude and body
rate: the plant samples the relative position before the IMU at a common stamp, so the navigation state
of that stamp is in it (the estimator node keeps that order). The thrusters' force guidance commands on
guidance/wrench (the tracking of an optimal approach) is a known input too: a constant acceleration over the
command's hold (one IMU period), turned into hill by the attitude estimate the command was computed from (the
stamp one period before the command's). Its execution error (the thrusters' magnitude and direction errors,
drawn once per run, so alike from one command to the next along an arc) is not modelled but measured: the
IMU's accelerometer gives the mean specific force over each IMU interval, which, turned into hill by the
attitude estimate of its stamp, is the thrust delta-v the interval really had; its difference from the
command's corrects the navigation state (``RelativeNavFilter.add_thrust_error``, with the accelerometer's
noise and the attitude estimate's error as covariance). A command that arrives after its interval's IMU
sample is taken as the delta-v the accelerometer measured. A rejected measurement is an event with the
running count of its kind. After the capture the chaser moves with the target, so its free-flight
navigation stops.

After the capture with a post_capture section (DESIGN §10): the target filter stops too (the target is no longer
torque-free), the chaser attitude filter goes on, and a ``ChaserEstimate`` is still given at every IMU sample
(guidance damps and excites the combined body from it), its position the chaser's at the capture, fixed in its own
axes (the navigation estimate at the simulator's ``captured`` stamp, turned with the attitude estimate). At guidance's
``damping_complete`` the mass-property filter runs over the excitation (``mass_estimation_run.MassEstimationRun``),
from the prior at the capture (``mass_estimation_run.mass_property_prior``); its estimates go out as
``TargetInertiaEstimate`` (estimation/target/inertia) with their 1-sigma on mission/events
(``mass_properties_estimate``, the last ``mass_properties_estimated``). A run that starts attached (post_capture.start
attached, seed 004 §3.1) is attached from t = 0: no free-flight navigation, the snapshot the attachment as known
(``mass_estimation_run.attachment_snapshot``), its chaser estimates' position that geometry about the target's initial
CoM (no position sensor), and the filter's run from guidance's ``excitation_scheduled``. With a transport
(post_capture.transport) the final estimate starts the combined body's navigation
(``transport_navigation.TransportNavigation``: relative position and accelerometer), whose chaser position and
velocity the chaser estimates carry from the next IMU sample on; at every stamp of
``transport_navigation.on_com_grid`` after it, before that stamp's chaser estimate, the combined CoM it navigates with
(``transport_com_estimate``: estimated with the translation, ``combined_com_filter.CombinedComFilter``), which
guidance waits for.

The estimator node and the headless driver (flyby_mission.headless) both run ``EstimatorCore``, built from its
parameter record (``params.EstimatorParams``: what it reads of the scenario); every input method returns the outputs
to publish, in order.
"""

import collections
import dataclasses
import math

import numpy as np

from flyby_estimation.chaser_attitude_filter import ChaserAttitudeFilter
from flyby_estimation.health import THRUST_SETTLE_S, HealthMonitor
from flyby_estimation.mass_estimation_run import (
    CaptureSnapshot,
    MassEstimationRun,
    attachment_snapshot,
    imu_sample,
    mass_property_prior,
)
from flyby_estimation.params import EstimatorParams
from flyby_estimation.relative_nav import RelativeNavFilter
from flyby_estimation.target_filter import TargetAttitudeFilter
from flyby_estimation.transport_navigation import TransportNavigation, combined_com_covariance
from flyby_msgs_py import contract as c
from flyby_msgs_py import event_payloads, events
from flyby_msgs_py.stamped import StampedBuffer, put_bounded, stamp_key
from flyby_msgs_py.wire import STAMP_TOLERANCE_S, Event
from flyby_sim.dynamics.attitude import body_point_state
from flyby_sim.dynamics.combined_body import combined_mass_properties
from flyby_sim.dynamics.propulsion import ManeuverRejected
from flyby_sim.dynamics.rotation import quat_rotate, quat_to_matrix, skew

# The variance [m^2, m^2/s^2] published for a chaser position and velocity that nothing measures (a start attached).
_NOT_ESTIMATED_VARIANCE = 1e6
# The category is re-evaluated this often once converged (it scans the attitude history) [s].
CLASSIFY_PERIOD_S = 10.0
# Attitude estimates kept for the force commands (computed from one of the last few).
_ATTITUDES_KEPT = 16
GATED = ('outlier', 'reset')  # an update the filter's gate refused (a stale or malformed one is not the sensor's)


@dataclasses.dataclass(frozen=True)
class TargetEstimate:
    """estimation/target/odom: attitude q_hill_from_body, inertial body rate omega_body [rad/s] (with any
    injected fault), the attitude covariance about hill axes [rad^2] and the rate covariance in body
    axes [rad^2/s^2] (3x3 each)."""

    t: float
    q_hill_from_body: np.ndarray
    omega_body: np.ndarray
    attitude_covariance_hill: np.ndarray
    rate_covariance_body: np.ndarray


@dataclasses.dataclass(frozen=True)
class ChaserEstimate:
    """estimation/chaser/odom: r_hill [m], v_hill [m/s] (relative to hill) and the 6x6 covariance of [r; v];
    with the rigid-body chaser also its attitude q_hill_from_body, inertial body rate omega_body [rad/s] and
    their covariances (attitude about hill axes [rad^2], rate in body axes [rad^2/s^2]), else None."""

    t: float
    r_hill: np.ndarray
    v_hill: np.ndarray
    covariance: np.ndarray
    q_hill_from_body: np.ndarray = None
    omega_body: np.ndarray = None
    attitude_covariance_hill: np.ndarray = None
    rate_covariance_body: np.ndarray = None


class EstimatorCore:
    """The estimator's rules (module doc)."""

    def __init__(self, params: EstimatorParams, name='flyby_estimator'):
        self.params = params
        self.name = name
        self.target = TargetAttitudeFilter(params.target.config())
        self.nav = RelativeNavFilter(params.nav.config())
        self.convergence = params.convergence
        self.motion = params.motion
        self.attitude = (ChaserAttitudeFilter(params.chaser_attitude.config())
                         if params.chaser_attitude is not None else None)
        self.converged = False
        self.checked = False  # the batch check runs at the first convergence
        self.category = None
        self.t_classified = -math.inf
        self.rejected = collections.Counter()
        # A fault to inject (tests of the escape): the published rate is off, the filter itself is not.
        self.rate_error = params.injected_rate_error_rad_s
        self.attached = False  # captured: the free-flyer navigation model no longer holds
        self.health = HealthMonitor(params.health)
        self.t_thrust_end = -math.inf  # the end of the latest firing the navigation filter models
        if self.attitude is not None:
            self.wrench_hold_s = 1.0 / params.imu_rate_hz  # guidance's control period
            # (t, q_hill_from_body) of the latest attitude estimates: a force command's is one period old
            self.attitudes = collections.deque(maxlen=_ATTITUDES_KEPT)
            self.accel_sigma_mps2 = params.accel_noise_sigma_mps2
            self.imu_t_last = None
            # Interval start (rounded stamp) -> the delta-v sent to the navigation filter for a force command
            # not yet measured, or the accelerometer's measured delta-v and covariance of an interval whose
            # force command has not come yet.
            self.commanded_dv = {}
            self.measured_dv = {}
        # After the capture (module doc): the estimates around it by stamp, what the capture fixed, the filter's run.
        self.post_capture = params.mass_estimation is not None
        self.transport_nav = None  # from the final mass-property estimate on, with a transport (module doc)
        if self.post_capture:
            self.recent_chaser, self.recent_target = StampedBuffer(200), StampedBuffer(200)
            self.snapshot = None
            self.mass_run = None
            self.pending = []  # IMU samples after the capture that came before its stamp did
            self.arm_deflection = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
            if params.mass_estimation.attachment is not None:  # held from t = 0 (module doc)
                self.attached = True
                self.health.suspend('target_attitude')  # as after a capture (on_phase)
                self.health.suspend_thrust()
                self.snapshot = attachment_snapshot(params.mass_estimation)
                self.capture_covariance = _NOT_ESTIMATED_VARIANCE * np.eye(6)  # no position sensor
                self.mass_run = MassEstimationRun(params.mass_estimation, params.chaser_mass_kg)

    # -- inputs ---------------------------------------------------------------------------------
    def on_phase(self, phase):
        if self.health.wheels is not None:
            self.health.wheels.pause(phase in (c.PHASE_CAPTURE, c.PHASE_GRASP))
        if phase != c.PHASE_CAPTURE or self.attached:
            return []
        self.attached = True
        self.health.suspend_thrust()
        for sensor in list(self.health.sensors) if not self.post_capture else ['target_attitude']:
            self.health.suspend(sensor)  # without a post_capture section the run ends attached
        t = self.nav.t if self.nav.initialized else 0.0
        return [self._event(t, 'OK', events.NAVIGATION_SUSPENDED,
                            'captured: the chaser moves with the target, its free-flight navigation filter stops', {})]

    def on_event(self, event):
        """An event of mission/events (wire.Event): the capture's stamp and the excitation's start (module doc)."""
        if not self.post_capture or event.source == self.name:
            return []
        if event.name == events.CAPTURED and self.snapshot is None and self.pending is not None:
            return self._take_snapshot(event.t)
        if event.name == events.GRASP_RELEASED:  # both fly freely: no combined body to estimate, no fixed relation
            self.snapshot, self.pending, self.mass_run = None, None, None
            return []
        if event.name == events.GRASP_DAMPED:
            damped = event_payloads.decode(event)
            self.arm_deflection = (list(damped.arm_displacement_body_m), list(damped.arm_rotation_body_rad))
            return []
        if event.name in (events.DAMPING_COMPLETE, events.EXCITATION_SCHEDULED) and self.mass_run is not None \
                and self.mass_run.t_start is None:
            return self._start_mass_estimation(event)
        return []

    def _start_mass_estimation(self, event):
        """The prior at the lock and the filter's run from the excitation's start (module doc)."""
        prior = mass_property_prior(self.params.mass_estimation, self.snapshot, *self.arm_deflection)
        excitation = event_payloads.decode(event)
        t_start = excitation.t_excitation_s
        started = self._event(event.t, 'OK', events.MASS_PROPERTIES_PRIOR,
                              f'prior of the target at the lock: {prior.target_mass_kg:.2f} kg, CoM '
                              f'{np.round(prior.target_com_body_m, 3).tolist()} m (chaser_body); the excitation from '
                              f't = {t_start:.2f} s',
                              {'mass_kg': prior.target_mass_kg, 'com_body_m': prior.target_com_body_m,
                               'principal_moments_kg_m2': prior.principal_moments_kg_m2,
                               'principal_axes_q': prior.q_body_from_principal,
                               'principal_axes_sigma_rad': prior.axes_sigma_rad})
        return [started] + self._mass_outputs(self.mass_run.start(
            t_start, list(excitation.h_wheels_body_n_m_s), prior))

    def _take_snapshot(self, t_capture):
        """What the capture fixed: the estimates stamped at (or last before) it, the prior and the filter's run."""
        chaser = self.recent_chaser.last_at_or_before(t_capture + STAMP_TOLERANCE_S)
        target = self.recent_target.last_at_or_before(t_capture + STAMP_TOLERANCE_S)
        if chaser is None or target is None:
            return [self._event(t_capture, 'WARN', events.MASS_ESTIMATION_UNAVAILABLE,
                                'no chaser or target estimate at the capture: no prior for the mass properties', {})]
        estimate = chaser[1]
        self.snapshot = CaptureSnapshot(t_capture, estimate.r_hill, estimate.q_hill_from_body,
                                        target[1].q_hill_from_body, target[1].attitude_covariance_hill)
        self.capture_covariance = estimate.covariance
        self.arm_deflection = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        self.mass_run = MassEstimationRun(self.params.mass_estimation, self.nav.mass_kg or self.params.chaser_mass_kg)
        pending, self.pending = self.pending, []
        return [out for args in pending for out in self._attached_imu(*args)]

    def _mass_outputs(self, estimates):
        """The filter's estimates and their 1-sigma events (module doc)."""
        out = []
        for e in estimates:
            f = e.estimate
            if e.final and self.params.transport is not None:
                combined = combined_mass_properties(self.mass_run.chaser_mass_kg,
                                                    self.params.mass_estimation.chaser_inertia, f.target_mass_kg,
                                                    f.target_com_body_m, f.target_inertia_body_kg_m2)
                self.transport_nav = TransportNavigation(
                    self.params.transport, e.t, combined.com_body_m,
                    combined_com_covariance(self.mass_run.chaser_mass_kg, f), combined.mass_kg)
            out.append(e)
            name = events.MASS_PROPERTIES_ESTIMATED if e.final else events.MASS_PROPERTIES_ESTIMATE
            payload = event_payloads.PAYLOADS[name](
                f.target_mass_kg, f.mass_sigma_kg, f.target_com_body_m, f.com_sigma_m, f.principal_moments_kg_m2,
                f.principal_moments_sigma_kg_m2, f.q_body_from_principal)
            out.append(self._event(e.t, 'OK', name,
                                   f'target {f.target_mass_kg:.2f} +- {f.mass_sigma_kg:.2f} kg, principal moments '
                                   f'{np.round(f.principal_moments_kg_m2, 1).tolist()} kg m^2'
                                   + (' (final)' if e.final else ''),
                                   event_payloads.encode(payload, {
                                    'principal_axes_sigma_rad': f.axes_sigma_rad,
                                    'imu_rejected': sum(v for k, v in self.mass_run.filter.imu_counts.items()
                                                        if k != 'accepted')})))
        return out

    def on_attitude(self, t, q_hill_from_body):
        """A vision attitude measurement at t; then the health monitors' judgement."""
        return self._attitude(t, q_hill_from_body) + self._health(t)

    def _attitude(self, t, q_hill_from_body):
        if self.attached and self.post_capture:
            return []  # the target is no longer torque-free (module doc)
        result = self.target.update(t, q_hill_from_body)
        self.health.on_sample('target_attitude', t, result.kind in GATED, result.nis)
        if not result.accepted:
            return self._reject(t, 'target_attitude', result.kind, result.reason)
        s = self.target.state()
        estimate = TargetEstimate(s.t, s.q_hill_from_body, s.omega_body + self.rate_error, s.covariance_hill[:3, :3],
                                  s.covariance[3:, 3:])
        if self.post_capture:
            self.recent_target.add(s.t, estimate)
        return [estimate] + self._check_convergence(s.t)

    def on_position(self, t, r_hill):
        """A relative-position measurement at t; then the health monitors' judgement."""
        return self._position(t, r_hill) + self._health(t)

    def _position(self, t, r_hill):
        if self.attached:
            self.health.on_sample('relative_position', t)
            if self.post_capture and self.transport_nav is not None:
                self.transport_nav.on_position(t, r_hill)
            return []
        result = self.nav.update(t, r_hill)
        self.health.on_sample('relative_position', t, result.kind in GATED, result.nis,
                              transient=self._thrust_transient(t))
        out = [] if result.accepted else self._reject(t, 'relative_position', result.kind, result.reason)
        if self.attitude is not None or not (result.accepted or result.kind == 'outlier'):
            return out  # the rigid body's is given with the attitude at the IMU's stamps
        s = self.nav.state()  # at an outlier its prediction: the consumers get an estimate at every sample
        return out + [ChaserEstimate(s.t, s.r_hill, s.v_hill, s.covariance)]

    def on_imu(self, t, q_hill_from_body, omega_body_meas, specific_force_body=None):
        """An IMU sample at t (rigid-body chaser): star-tracker attitude q_hill_from_body or None, gyro rate, and
        the accelerometer's mean specific force [m/s^2, chaser_body] since the previous sample (or None); then the
        health monitors' judgement."""
        return self._imu(t, q_hill_from_body, omega_body_meas, specific_force_body) + self._health(t)

    def _imu(self, t, q_hill_from_body, omega_body_meas, specific_force_body):
        if self.attitude is None or (self.attached and not self.post_capture):
            return []
        out = []
        self.health.on_sample('imu', t)
        self.health.wheels.on_sample(t, omega_body_rad_s=omega_body_meas)
        for sensor, result in zip(('gyro', 'star_tracker'), self.attitude.on_imu(t, omega_body_meas, q_hill_from_body),
                                  strict=True):
            if sensor == 'star_tracker' and result is not None:
                self.health.on_sample('star_tracker', t, result.kind in GATED, result.nis)
            if result is not None and not result.accepted:
                out += self._reject(t, sensor, result.kind, result.reason)
        t_last, self.imu_t_last = self.imu_t_last, t
        if not (self.attitude.ready and (self.nav.initialized or self.attached)):
            return out
        a = self.attitude.estimate()
        if self.attached:
            return out + self._attached_imu(t, a, specific_force_body, q_hill_from_body)
        self.attitudes.append((a.t, a.q_hill_from_body))
        if specific_force_body is not None and t_last is not None:
            rejected = self._measured_thrust(t_last, t, a, specific_force_body)
            out += rejected
            if self.health.thrust is not None and not rejected:  # a non-finite sample judges nothing
                self.health.on_interval(self.nav.burns, t_last, t, a.q_hill_from_body, specific_force_body,
                                        self.nav.mass_kg or self.params.chaser_mass_kg)
        s = self.nav.state() if self.nav.t >= t else self.nav.predict(t)
        estimate = ChaserEstimate(a.t, s.r_hill, s.v_hill, s.covariance, a.q_hill_from_body, a.omega_body,
                                  a.attitude_covariance_hill, a.rate_covariance)
        if self.post_capture:
            self.recent_chaser.add(a.t, estimate)
        return out + [estimate]

    def _attached_imu(self, t, a, specific_force_body, q_star_hill):
        """An IMU sample after the capture (module doc): the chaser estimate, then the mass-property filter's."""
        if self.snapshot is None:
            if self.pending is not None:  # None after the arm let go
                self.pending.append((t, a, specific_force_body, q_star_hill))
            return []
        c_hill_from_body = quat_to_matrix(a.q_hill_from_body)
        r_hill, v_hill = body_point_state(c_hill_from_body, a.omega_body, self.snapshot.r_chaser_body,
                                          self.params.mean_motion_rad_s)
        r_hill = r_hill + self.snapshot.r_target_hill
        covariance = self.capture_covariance
        out = []
        if self.transport_nav is not None:
            navigated, refined = self.transport_nav.on_imu(t, a, specific_force_body)
            if navigated is not None:
                r_hill, v_hill, covariance = navigated
            if refined is not None:  # before the estimate: guidance waits for it at this stamp
                com, sigma, coast_s = refined
                coast = f' ({coast_s:.0f} s after a firing)' if coast_s else ''
                known = navigated is not None
                payload = event_payloads.TransportComEstimate(
                    com, sigma, coast_s,
                    position_sigma_m=float(np.sqrt(np.max(np.diag(covariance)[:3]))) if known else None,
                    velocity_sigma_mps=self.transport_nav.velocity_sigma_mps() if known else None)
                nav = '' if not known else (f'; navigation 1-sigma {payload.position_sigma_m:.3g} m, '
                                            f'{payload.velocity_sigma_mps:.3g} m/s')
                out.append(self._event(t, 'OK', events.TRANSPORT_COM_ESTIMATE,
                                       f'combined CoM {np.round(com, 4).tolist()} m from the chaser\'s, +- '
                                       f'{np.round(sigma * 1e3, 2).tolist()} mm{coast}{nav}',
                                       event_payloads.encode(payload)))
        out.append(ChaserEstimate(a.t, r_hill, v_hill, covariance, a.q_hill_from_body, a.omega_body,
                                  a.attitude_covariance_hill, a.rate_covariance))
        if specific_force_body is None:
            return out
        sample = imu_sample(t, a, specific_force_body, q_star_hill, self.params.mean_motion_rad_s)
        return out + self._mass_outputs(self.mass_run.on_sample(sample))

    def on_maneuver(self, t, dv_hill):
        """A commanded maneuver (stamp t, dv_hill): a known input of the navigation filter."""
        try:
            burn = self.nav.add_maneuver(t, dv_hill)
        except (ManeuverRejected, ValueError) as err:
            # The simulator rejects it too; the filter must not expect it.
            return [self._event(t, 'WARN', events.MANEUVER_IGNORED,
                                f'not a known input of the navigation filter: {err}', {'t_stamp': t})]
        if self.health.thrust is not None:
            self.health.book.on_maneuver(burn.seq)
        return []

    def on_cam(self, t):
        """The independent monitor's CAM from t (safety/cam): thrust the navigation does not model, at full force. The
        thrust monitor stops (its burn is none of guidance's) and the relative position's innovation rules wait
        from then on (the escape is flown)."""
        self.health.suspend_thrust()
        self.t_thrust_end = math.inf
        return []

    def on_wheels(self, t, torques_n_m):
        """Guidance's wheel motor torques [N m] held from t (guidance/wheels): what the wheel monitor expects."""
        if self.health.wheels is not None:
            self.health.wheels.on_command(t, torques_n_m)
        return []

    def on_wheel_speeds(self, t, speeds_rad_s):
        """The wheels' tachometers at t [rad/s] (sensors/chaser/wheels); then the health monitors' judgement."""
        if self.health.wheels is None or (self.attached and not self.post_capture):
            return []
        self.health.on_sample('tachometers', t)
        self.health.wheels.on_sample(t, speeds_rad_s=speeds_rad_s)
        return self._health(t)

    def on_wrench(self, t, force_body_n, torque_body_n_m=(0.0, 0.0, 0.0)):
        """A commanded thruster force [N, chaser_body] (and torque [N m]) held from t for one control period
        (guidance/wrench): a known input of the navigation filter (module doc). One below the minimum impulse bit is
        left out (the thrusters do not give it either)."""
        force = np.asarray(force_body_n, dtype=float)
        if self.transport_nav is not None:
            self.transport_nav.on_command(t, force, torque_body_n_m)
        if self.attitude is None or self.attached:
            return []
        t_estimate = t - self.wrench_hold_s
        # Turned into hill at the attitude estimate the command was computed from, which every pace has by then.
        q = next((q for t_q, q in reversed(self.attitudes) if t_q <= t_estimate + STAMP_TOLERANCE_S), None)
        if q is None:
            return []
        mass_kg = self.nav.mass_kg or self.params.chaser_mass_kg
        dv_hill = quat_rotate(q, force) * (self.wrench_hold_s / mass_kg)
        if self.health.thrust is not None:  # what the thrust monitor expects of the interval
            self.health.book.on_command(t, dv_hill, force, torque_body_n_m)
        if not np.any(force):
            return []
        if float(np.linalg.norm(force)) * self.wrench_hold_s < self.params.min_impulse_bit_ns:
            return []
        measured = self.measured_dv.pop(stamp_key(t), None)
        if measured is not None:  # its interval's accelerometer sample came first
            dv_hill = measured
        try:
            self.nav.add_maneuver(t, dv_hill, burn_duration_s=self.wrench_hold_s, execution_error=False)
        except (ManeuverRejected, ValueError) as err:
            return [self._event(t, 'WARN', events.MANEUVER_IGNORED,
                                f'force command not a known input of the navigation filter: {err}', {'t_stamp': t})]
        if measured is None:
            put_bounded(self.commanded_dv, stamp_key(t), dv_hill, _ATTITUDES_KEPT)
        return []

    def _measured_thrust(self, t_start, t_end, attitude, specific_force_body):
        """The accelerometer's thrust delta-v over [t_start, t_end] against the force command's (module doc)."""
        commanded = self.commanded_dv.pop(stamp_key(t_start), None)
        f = np.asarray(specific_force_body, dtype=float)
        if not np.all(np.isfinite(f)):
            return self._reject(t_end, 'accelerometer', 'non_finite', f'specific force {specific_force_body!r}')
        dv_hill = quat_rotate(attitude.q_hill_from_body, f) * (t_end - t_start)
        # The accelerometer's noise on the mean over the interval, and the attitude estimate's error turning it.
        dv_cross = skew(dv_hill)
        cov = ((self.accel_sigma_mps2 * (t_end - t_start))**2 * np.eye(3)
               + dv_cross @ attitude.attitude_covariance_hill @ dv_cross.T)
        if commanded is None:
            if float(np.linalg.norm(dv_hill)) > 3.0 * self.accel_sigma_mps2 * (t_end - t_start):
                # a command still on its way: taken as this
                put_bounded(self.measured_dv, stamp_key(t_start), dv_hill, _ATTITUDES_KEPT)
            return []
        if self.nav.t < t_end:
            self.nav.propagate_to(t_end)
        self.nav.add_thrust_error(t_start, t_end, dv_hill - commanded, cov)
        return []

    # -- target convergence and category --------------------------------------------------------
    def _check_convergence(self, t):
        out = []
        converged = self.target.convergence(self.convergence)
        if converged != self.converged:
            self.converged = converged
            attitude_3s, rate_3s = self.target.three_sigma()
            bounds = {'attitude_3sigma_deg': f'{math.degrees(attitude_3s):.4g}',
                      'rate_3sigma_deg_s': f'{math.degrees(rate_3s):.4g}'}
            if converged and not self.checked:
                self.checked = True
                figures, out = self._batch_check(t)
                bounds.update(figures)
            out.append(self._event(t, 'OK' if converged else 'WARN',
                                   events.TARGET_CONVERGED if converged else events.TARGET_DIVERGED,
                                   f'target estimate {"within" if converged else "outside"} the convergence bounds',
                                   bounds))
        if converged and t >= self.t_classified + CLASSIFY_PERIOD_S:
            self.t_classified = t
            motion = self.target.classify_motion(self.motion)
            if motion.category != self.category:
                self.category = motion.category
                out.append(self._event(t, 'OK', events.TARGET_CATEGORY, motion.reason,
                                       {'category': motion.category,
                                        'inertial_rate_deg_s': f'{math.degrees(motion.inertial_rate_rad_s):.4g}',
                                        'hill_relative_rate_deg_s':
                                            f'{math.degrees(motion.hill_relative_rate_rad_s):.4g}'}))
        return out

    def _batch_check(self, t):
        """The filter against the batch maximum-likelihood fit of its measurements (batch.FilterCheck):
        (its figures for the converged event, a WARN target_filter_check if they disagree)."""
        try:
            check = self.target.batch_check()
        except (RuntimeError, ValueError) as err:
            return {}, [self._event(t, 'WARN', events.TARGET_FILTER_CHECK, f'batch check not done: {err}', {})]
        values = {'ml_gap_sigma': f'{check.gap_sigma:.3g}', 'crb_ratio_min': f'{check.ratio_min:.3g}',
                  'crb_ratio_max': f'{check.ratio_max:.3g}', 'chi2_per_dof': f'{check.chi2_per_dof:.4g}',
                  'window_samples': str(check.fit.samples)}
        if check.consistent:
            return values, []
        return values, [self._event(t, 'WARN', events.TARGET_FILTER_CHECK,
                                    'the filter differs from the batch maximum-likelihood fit of its measurements '
                                    f'(gap {check.gap_sigma:.3g} sigma, covariance {check.ratio_min:.3g}-'
                                    f'{check.ratio_max:.3g} x the Cramer-Rao bound)', values)]

    # -- events ---------------------------------------------------------------------------------
    def _thrust_transient(self, t):
        """Whether the navigation filter is within ``health.THRUST_SETTLE_S`` of a firing it models (its execution
        error settles in the innovations: the relative position's innovation rules wait, ``health``)."""
        for b in self.nav.burns:
            if b.start_s <= t + STAMP_TOLERANCE_S:
                self.t_thrust_end = max(self.t_thrust_end, b.end_s)
        return t < self.t_thrust_end + THRUST_SETTLE_S

    def _health(self, t):
        """The health monitors judged at stamp t: their detections as events, their statuses (``health``)."""
        out = []
        detections, diagnostics = self.health.judge(t)
        for d in detections:
            record = event_payloads.FaultDetected if d.detected else event_payloads.FaultRecovered
            values = dict(d.values)
            candidates = values.pop('candidates', None)
            payload = record(d.monitor, d.kind, d.component, d.t, None if candidates is None else tuple(candidates))
            out.append(self._event(t, 'ERROR' if d.detected else 'OK',
                                   events.FAULT_DETECTED if d.detected else events.FAULT_RECOVERED, d.message,
                                   event_payloads.encode(payload, values)))
        return out + ([] if diagnostics is None else [diagnostics])

    def _reject(self, t, sensor, kind, reason):
        self.rejected[(sensor, kind)] += 1
        return [self._event(t, 'WARN', events.MEASUREMENT_REJECTED, reason,
                            {'sensor': sensor, 'kind': kind, 'count': str(self.rejected[(sensor, kind)]),
                             'total': str(sum(self.rejected.values()))})]

    def _event(self, t, level, name, message, values):
        return Event(t, level, name, message, values, self.name)
