"""The plant: chaser relative translation with finite burns, target attitude, sensors, events.

The chaser is a point mass (the default) or, when the configuration has a ``chaser_body``
(``RigidChaserConfig``, scenario ``chaser.model: rigid_body``), the six-degree-of-freedom chaser of
``flyby_sim.chaser_body``: attitude, reaction wheels, body-fixed thrusters, wrench and wheel commands and an
IMU (docs/chaser_6dof.md). The point-mass chaser's truth, measurements and events do not depend on anything
the rigid-body chaser adds.

After the capture (``capture``) the chaser is welded to the target where it is, unless the configuration has a
``grasp`` (scenario ``post_capture``, issue 16, docs/post_capture.md; the rigid-body chaser): then the arm's
impedance joins the two free bodies (``dynamics.grasp.simulate_grasp``, from the first contact, in the inertial
frame that coincides with hill at the capture; the orbit is left out over the seconds of the grasp) until the
relative motion is damped and the arm locks (``grasp_damped``), or beyond the arm's limits lets go
(``grasp_released``: both fly on freely, the target off the hill origin). Once locked, chaser and target are one
rigid body (``dynamics.grasp.weld``: the true combined mass properties, the momentum both carried) whose CoM
moves by the relative orbital dynamics and whose thrusters act at their true positions about the combined CoM
(``chaser_body.SixDofChaser`` with ``com_body_m``); wrench and wheel commands stamped from one IMU period after the
lock on apply to it (earlier ones, from before the capture, are ignored). The target's truth then carries its CoM
off the hill origin (``TruthSample.r_target_hill``), and the IMU's accelerometer, at the chaser's CoM, reads the
combined body's rotation too (seed 004 section 2.2: F/(m + M) + omega_dot x p + omega x (omega x p)). A run that
starts attached (scenario ``post_capture.start: attached``, seed 004 section 3.1) is that combined body from t = 0
(event ``attached``), the target's CoM at X_s from the chaser's and turning with it; commands from one IMU period on.

Pure numpy/scipy, no ROS: the simulator node wraps it, Monte Carlo drives it directly.

Frames and conventions are those of ``flyby_sim.dynamics.orbital`` (hill, ECI) with quaternions (x, y, z, w),
scalar last. The target's attitude is integrated in ECI (q_eci_from_body, seed 000 eq 4) and
reported in hill: q_hill_from_body(t) = q_hill_from_eci(t) * q_eci_from_body(t), where the hill
axes turn by n t about ECI +z. ``omega_body`` is always the target's inertial angular velocity
in body axes.

Determinism: time advances as step_index * step_s; the chaser is integrated with fixed-step RK4 whose
steps are split at every burn start and end, so thrust timing is exact to the sim time; burns are
fixed by the command stamps (thrusters module); the attitude integrator is never restarted; every
random draw comes from seed-derived streams, one per consumer (thrusters, each sensor). Truth thus
depends only on the configuration and the commands (stamps, values, order), not on when before
its stamp a command arrived.

Cost: Monte Carlo steps the plant some 10^4 times a run, so the chaser is integrated on Python floats
(``rk4_step_floats``, the same arithmetic as the numpy RK4) and the target attitude, which the
commands never change, is evaluated ahead for a chunk of steps at a time (``AttitudePropagator.states_at``,
``q_hill_from_body_many``); both give the same numbers to the bit as one step at a time.
"""

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from flyby_msgs_py.wire import Event
from flyby_sim.chaser_body import ImuConfig, RigidChaserConfig, SixDofChaser
from flyby_sim.dynamics.actuators import plume_free_thrusters
from flyby_sim.dynamics.attitude import AttitudePropagator, body_point_state, validated_inertia
from flyby_sim.dynamics.checks import finite_vector, require_positive
from flyby_sim.dynamics.constants import MU_EARTH_M3_S2
from flyby_sim.dynamics.grasp import Body, Contact, Impedance, simulate_grasp, weld
from flyby_sim.dynamics.orbital import (
    mean_motion_rad_s,
    q_eci_from_body,
    q_hill_from_body,
    q_hill_from_body_many,
    quat_eci_from_hill,
    relative_accel_components,
    rk4_step_floats,
)
from flyby_sim.dynamics.propulsion import ManeuverRejected, ThrusterConfig
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_multiply,
    quat_normalize,
    quat_rotate,
    quat_to_matrix,
    rotation_vector_from_quat,
)
from flyby_sim.dynamics.sampling import SampleSchedule
from flyby_sim.sensors import ImuModel, SensorModel
from flyby_sim.thrusters import ThrusterModel

DYNAMICS = ('nonlinear', 'cw')
_ZERO3 = (0.0, 0.0, 0.0)
ATTITUDE_CHUNK_STEPS = 100  # steps of target attitude evaluated at once (5 s at 20 Hz)


@dataclasses.dataclass(frozen=True)
class GraspConfig:
    """The arm after the capture (scenario ``post_capture.grasp``; validated, ValueError names the field)."""

    impedance: Impedance
    target_mass_kg: float
    grasp_point_body_m: tuple  # the handle, target_body from its CoM [m]
    velocity_tolerance_mps: float = 1e-3  # damped once the relative velocity ...
    rate_tolerance_rad_s: float = 1e-3  # ... and rate stay below these
    max_duration_s: float = 20.0  # the arm locks at the latest this long after the first contact
    # Starting attached (scenario post_capture.start attached, seed 004 §3.1): the target's CoM X_s from the chaser's
    # CoM [m] and its attitude in the chaser's, (x, y, z, w), from t = 0; None: the run starts free.
    attached_target_com_body_m: tuple = None
    q_chaser_from_target: tuple = None
    # Transport (scenario post_capture.transport): the half-angle of the cone about the target's CoM that no
    # thruster's exhaust may point into once TRANSPORT starts [deg]; None: no transport.
    transport_plume_cone_deg: float = None

    def __post_init__(self):
        if not isinstance(self.impedance, Impedance):
            raise ValueError(f'impedance must be a grasp.Impedance, got {self.impedance!r}')
        for name in ('target_mass_kg', 'velocity_tolerance_mps', 'rate_tolerance_rad_s', 'max_duration_s'):
            require_positive(name, getattr(self, name))
        object.__setattr__(self, 'grasp_point_body_m', finite_vector('grasp_point_body_m', self.grasp_point_body_m, 3))
        if (self.attached_target_com_body_m is None) != (self.q_chaser_from_target is None):
            raise ValueError('attached_target_com_body_m and q_chaser_from_target go together (start attached) or '
                             'are both None')
        if self.attached_target_com_body_m is not None:
            object.__setattr__(self, 'attached_target_com_body_m',
                               finite_vector('attached_target_com_body_m', self.attached_target_com_body_m, 3))
            object.__setattr__(self, 'q_chaser_from_target', tuple(quat_normalize(
                finite_vector('q_chaser_from_target', self.q_chaser_from_target, 4))))

    @property
    def start_attached(self):
        """True when the run starts with the chaser holding the target."""
        return self.attached_target_com_body_m is not None


@dataclasses.dataclass(frozen=True)
class PlantConfig:
    """Everything the plant needs; validated on construction (ValueError names the field)."""

    radius_m: float  # circular target orbit radius
    chaser_mass_kg: float
    r0_hill: tuple  # chaser position at t = 0 [m]
    v0_hill: tuple  # chaser velocity relative to the rotating hill frame at t = 0 [m/s]
    target_inertia: tuple  # 3x3 [kg m^2], body axes
    q_hill_from_body0: tuple  # target attitude at t = 0, (x, y, z, w)
    omega_body0: tuple  # target inertial angular velocity at t = 0, body axes [rad/s]
    thrusters: ThrusterConfig
    mu: float = MU_EARTH_M3_S2
    dynamics: str = 'nonlinear'  # 'nonlinear' (seed 000 eq 1) or 'cw' (eq 2)
    step_s: float = 0.05
    position_sigma_m: float = 0.0
    position_rate_hz: float = 10.0
    attitude_sigma_rad: float = 0.0
    attitude_rate_hz: float = 10.0
    restriction_sphere_radius_m: float = 0.0
    seed: int = 0
    chaser_body: RigidChaserConfig = None  # None: the point-mass chaser
    grasp: GraspConfig = None  # None: the capture welds the chaser to the target (module doc)

    def __post_init__(self):
        for name in ('radius_m', 'chaser_mass_kg', 'mu', 'step_s', 'position_rate_hz', 'attitude_rate_hz'):
            require_positive(name, getattr(self, name))
        for name in ('position_sigma_m', 'attitude_sigma_rad', 'restriction_sphere_radius_m'):
            require_positive(name, getattr(self, name), allow_zero=True)
        for name, size in (('r0_hill', 3), ('v0_hill', 3), ('q_hill_from_body0', 4), ('omega_body0', 3)):
            object.__setattr__(self, name, finite_vector(name, getattr(self, name), size))
        try:
            inertia = validated_inertia(self.target_inertia)
        except ValueError as exc:
            raise ValueError(f'target_inertia: {exc}') from exc
        object.__setattr__(self, 'target_inertia', tuple(map(tuple, inertia.tolist())))
        try:
            quat_normalize(self.q_hill_from_body0)
        except ValueError as exc:
            raise ValueError(f'q_hill_from_body0: {exc}') from exc
        if self.dynamics not in DYNAMICS:
            raise ValueError(f'dynamics must be one of {DYNAMICS}, got {self.dynamics!r}')
        if not isinstance(self.thrusters, ThrusterConfig):
            raise ValueError(f'thrusters must be a ThrusterConfig, got {self.thrusters!r}')
        for name in ('position_rate_hz', 'attitude_rate_hz'):
            if getattr(self, name) * self.step_s > 1.0:
                raise ValueError(f'{name} = {getattr(self, name)} exceeds one sample per step '
                                 f'(step_s = {self.step_s})')
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise ValueError(f'seed must be a non-negative integer, got {self.seed!r}')
        if self.chaser_body is not None:
            if not isinstance(self.chaser_body, RigidChaserConfig):
                raise ValueError(f'chaser_body must be a RigidChaserConfig or None, got {self.chaser_body!r}')
            if self.chaser_body.imu.rate_hz * self.step_s > 1.0:
                raise ValueError(f'chaser_body.imu.rate_hz = {self.chaser_body.imu.rate_hz} exceeds one sample per '
                                 f'step (step_s = {self.step_s})')
        if self.grasp is not None:
            if not isinstance(self.grasp, GraspConfig):
                raise ValueError(f'grasp must be a GraspConfig or None, got {self.grasp!r}')
            if self.chaser_body is None:
                raise ValueError('grasp needs the rigid-body chaser (chaser_body)')

    @property
    def rigid_body(self):
        """True for the six-degree-of-freedom chaser."""
        return self.chaser_body is not None


@dataclasses.dataclass(frozen=True, slots=True)
class TruthSample:
    """True state at the end of a step (hill frame; arrays are the caller's to keep)."""

    t: float  # [s]
    r_hill: np.ndarray  # chaser position [m]
    v_hill: np.ndarray  # chaser velocity relative to the rotating frame [m/s]
    q_hill_from_body: np.ndarray  # target attitude (x, y, z, w)
    omega_body: np.ndarray  # target inertial angular velocity, body axes [rad/s]
    force_hill: np.ndarray  # mean thrust force over the step (impulse / step_s) [N]
    mass_kg: float  # chaser mass
    fuel_used_kg: float  # since t = 0
    dv_applied_total_mps: float  # sum of |delta-v| delivered by the thrusters since t = 0
    firing: bool  # thrust was on during some part of the step
    # The six-degree-of-freedom chaser only (None for the point mass); means are over the step.
    q_hill_from_chaser_body: np.ndarray = None  # chaser attitude (x, y, z, w)
    omega_chaser_body: np.ndarray = None  # chaser inertial angular velocity, chaser_body axes [rad/s]
    wheel_momentum_n_m_s: np.ndarray = None  # (N,) each wheel's axial angular momentum
    wheel_speed_rad_s: np.ndarray = None  # (N,) each wheel's spin rate relative to the body
    wheel_torque_n_m: np.ndarray = None  # (N,) mean motor torque applied (limits included)
    force_body_n: np.ndarray = None  # mean thrust force, chaser_body axes [N]
    torque_body_n_m: np.ndarray = None  # mean thrust torque about the CoM, chaser_body axes [N m]
    torque_hill_n_m: np.ndarray = None  # the same torque in hill axes (angular impulse / step_s) [N m]
    thruster_thrust_n: np.ndarray = None  # (M,) mean thrust of each thruster, errors included [N]
    gyro_bias_rad_s: np.ndarray = None  # the IMU gyro's bias (as of its latest sample) [rad/s]
    # The target's CoM off the hill origin after a grasp (None: at the origin): position and velocity relative to the
    # rotating frame, hill axes [m, m/s].
    r_target_hill: np.ndarray = None
    v_target_hill: np.ndarray = None


class Measurement(NamedTuple):
    """One sensor sample: kind 'relative_position' (value r_hill [m]), 'target_attitude' (q_hill_from_body) or,
    for the six-degree-of-freedom chaser, 'chaser_imu' (a sensors.ImuSample)."""

    kind: str
    t: float
    value: np.ndarray


class Plant:
    """Truth simulation of one chaser and its target, advanced in fixed steps of config.step_s.

    Events (drain_events): 'burn_started' and 'burn_ended' (OK), 'late_maneuver' (WARN, when a burn
    starts after its stamp), 'maneuver_rejected' (ERROR, with the ManeuverRejected reason) and
    'thrust_inside_restriction_sphere' (ERROR, once per burn, checked at both ends of every thrusting
    sub-step). The six-degree-of-freedom chaser adds 'late_command' (WARN, a wrench or wheel command stamped
    before the current time, applied at once), 'wrench_undelivered' (WARN, once per wrench command the
    thrusters cannot give in full), 'wrench_limited_by_burn' (WARN), 'wheel_torque_limited' and
    'wheel_momentum_limited' (WARN, once per wheel command), 'command_ignored' (WARN, after a capture), and
    reports 'thrust_inside_restriction_sphere' for any firing (once per burn and per run of consecutive wrench
    commands that fire inside the sphere). With a grasp (module doc): 'grasp_damped' (OK, the arm locked: its
    peak force and torque and the damping time) or 'grasp_released' (WARN, why), at the step they happen.
    """

    def __init__(self, config):
        self.config = config
        n = mean_motion_rad_s(config.radius_m, config.mu)
        self.mean_motion_rad_s = n
        self._accel = relative_accel_components(config.dynamics, n, config.radius_m)
        root_seed = np.random.SeedSequence(config.seed)
        thruster_seed, sensor_seed = root_seed.spawn(2)
        self._thrusters = ThrusterModel(config.thrusters, np.random.default_rng(thruster_seed))
        sensor_rng = np.random.default_rng(sensor_seed)
        self._sensors = SensorModel(sensor_rng, config.position_sigma_m, config.attitude_sigma_rad)
        q_eci_from_body0 = q_eci_from_body(0.0, n, quat_normalize(config.q_hill_from_body0))
        self._attitude = AttitudePropagator(q_eci_from_body0, config.omega_body0, config.target_inertia)
        self._attitude_chunk = (0, [], [])  # first step index, q_hill_from_body rows, omega_body rows
        self._position_schedule = SampleSchedule(config.position_rate_hz, config.step_s)
        self._attitude_schedule = SampleSchedule(config.attitude_rate_hz, config.step_s)
        self._step_index = 0
        self._y = list(config.r0_hill + config.v0_hill)  # [r_hill; v_hill] as floats
        self._mass_kg = config.chaser_mass_kg
        self._dv_total_mps = 0.0
        self._burn_rhs = None
        self._restriction_reported = False
        self._r_body_captured = None
        self._mode = 'free'  # then 'attached' (welded where it is), or 'grasp' and 'combined' or 'released'
        self._target_now = None  # (q_hill_from_body, omega_body, r_hill, v_hill) of the target after a grasp
        self._transport_mask = None  # the thrusters allowed in TRANSPORT (start_transport)
        self._events = []
        self._measurements = []
        self._chaser = self._imu = self._body = None
        if config.chaser_body is not None:
            self._init_rigid_body(root_seed, sensor_rng)
            self._last = self._truth_rigid(self._chaser.totals)
            if config.grasp is not None and config.grasp.start_attached:
                self._start_attached()
        else:
            self._last = self._truth(np.zeros(3), False)

    def _init_rigid_body(self, root_seed, sensor_rng):
        """The six-degree-of-freedom chaser and its IMU, from streams spawned after the point-mass ones (a third
        child of the root seed for the thruster errors, a third of the sensor generator for the IMU), so the
        other sensors' draws are unchanged."""
        config = self.config
        body = config.chaser_body
        self._chaser = SixDofChaser(body, config.thrusters, config.r0_hill, config.v0_hill, config.chaser_mass_kg,
                                    self.mean_motion_rad_s, self._accel, config.step_s,
                                    config.restriction_sphere_radius_m,
                                    np.random.default_rng(root_seed.spawn(1)[0]), self._events_append)
        imu = body.imu
        self._imu = ImuModel(sensor_rng.spawn(1)[0], imu.star_tracker_sigma_rad, imu.gyro_noise_sigma_rad_s,
                             imu.gyro_bias_sigma_rad_s, imu.gyro_bias_walk_rad_s_sqrt_s, imu.accel_noise_sigma_mps2)
        self._imu_schedule = SampleSchedule(imu.rate_hz, config.step_s)
        self._star_tracker_every = imu.star_tracker_every
        self._q_target_from_chaser = None
        self._imu_dv_hill = [0.0, 0.0, 0.0]  # non-gravitational delta-v since the last IMU sample, hill axes [m/s]
        self._imu_t_last = 0.0
        self._imu_omega_last = None  # the combined body's rate at the last IMU sample (its omega_dot x p term)
        self._body = self._chaser  # the rigid body integrated: the chaser, or the combined body after a grasp

    def _events_append(self, event):
        self._events.append(event)

    @property
    def chaser(self):
        """The six-degree-of-freedom chaser (``chaser_body.SixDofChaser``: layout, wheels, errors), or None."""
        return self._chaser

    @property
    def t(self):
        """Current sim time [s]."""
        return self._step_index * self.config.step_s

    def truth(self):
        """The TruthSample of the current time (the last step's, or the initial state)."""
        return self._last

    def command_maneuver(self, t_stamp, dv_hill):
        """Schedule an impulsive delta-v dv_hill [m/s] to start at sim time t_stamp [s].

        Returns the thrusters.Burn as scheduled now (start_s, end_s, late, dv_hill to be delivered); for the
        six-degree-of-freedom chaser a chaser_body.ManeuverRequest (the burn's direction and duration are fixed
        when it starts, at the attitude then: the burn_started event).
        Raises ManeuverRejected (and records an ERROR event) for an unexecutable command.
        """
        try:
            if self.captured:
                raise ManeuverRejected(f'the chaser is attached to the target; maneuver stamped {t_stamp} s dropped')
            if self._chaser is not None:
                return self._chaser.command_maneuver(self.t, t_stamp, dv_hill)
            return self._thrusters.schedule(t_stamp, dv_hill, self.t, self._mass_kg)
        except ManeuverRejected as exc:
            self._events.append(Event(self.t, 'ERROR', 'maneuver_rejected', exc.reason,
                                      dict(t_now=self.t, t_stamp=t_stamp, dv_hill=str(dv_hill))))
            raise

    def command_wrench(self, t_stamp, force_body_n, torque_body_n_m, hold_s=None):
        """Hold the thrusters' body force [N] and torque about the CoM [N m] (chaser_body axes) from sim time
        t_stamp [s] until the next wrench command (zero-order hold; DESIGN §10 /guidance/wrench).

        Allocated once (least fuel, ``actuators.allocate_wrench``); a thruster stays off if its thrust would give
        less than the minimum impulse bit over hold_s [s], the hold the controller means (its control period;
        default one plant step); what the thrusters cannot give is reported (``wrench_undelivered``). Stamped
        before now: applied at once and reported (``late_command``). Returns the chaser_body.WrenchCommand, or
        None after a capture (``command_ignored``). Raises ValueError for a point-mass chaser or a non-finite
        command.
        """
        self._rigid_chaser('command_wrench')
        if not self._accepts_command(t_stamp):
            return self._ignored('wrench', t_stamp)
        return self._body.command_wrench(self.t, t_stamp, force_body_n, torque_body_n_m, hold_s)

    def command_wheels(self, t_stamp, torque_n_m):
        """Hold the reaction wheels' motor torques [N m] (one per wheel) from sim time t_stamp [s] until the next
        wheel command; limits as ``GyrostatPropagator`` (``wheel_torque_limited``, ``wheel_momentum_limited``).
        Stamped before now: applied at once (``late_command``). Returns the chaser_body.WheelCommand, or None
        after a capture. Raises ValueError for a point-mass chaser or a non-finite command.
        """
        self._rigid_chaser('command_wheels')
        if not self._accepts_command(t_stamp):
            return self._ignored('wheels', t_stamp)
        return self._body.command_wheels(self.t, t_stamp, torque_n_m)

    def _accepts_command(self, t_stamp):
        """Free flight, or the combined body for a command stamped from one IMU period after the lock on (the first
        the controller computes from the combined body's IMU, DESIGN §10)."""
        if self._mode == 'combined':
            return t_stamp >= self._t_locked + 1.0 / self.config.chaser_body.imu.rate_hz - 1e-6
        return not self.captured

    def _rigid_chaser(self, what):
        if self._chaser is None:
            raise ValueError(f'{what}: the point-mass chaser has no attitude, thrusters or wheels '
                             f'(chaser.model: rigid_body)')
        return self._chaser

    def _ignored(self, kind, t_stamp):
        self._events.append(Event(self.t, 'WARN', 'command_ignored',
                                  f'{kind} command stamped {t_stamp} s ignored: the chaser is attached to the target'
                                  + (' (stamped before the arm locked)' if self._mode == 'combined' else ''),
                                  dict(command=kind, t_stamp=t_stamp)))

    def measurements(self):
        """Sensor samples due at the last step (list of Measurement)."""
        return self._measurements

    def drain_events(self):
        """Events since the last call, oldest first (list of Event)."""
        events, self._events = self._events, []
        return events

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
        self._events.append(Event(self.t, 'OK', 'captured', f'chaser attached to the target at t = {self.t:.3f} s',
                                  dict(t=self.t, r_hill=np.array(self._y[:3]), r_body=self._r_body_captured)))

    # -- after the capture with a grasp (module doc) -----------------------------------------------
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
        self._events.append(Event(t0, 'OK', 'captured', f'the manipulator grasps the target at t = {t0:.3f} s',
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
        self._events.append(Event(self.t, 'OK', 'attached',
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
            self._body.restrict_thrusters(self._transport_mask)
            self._events.append(Event(self.t, 'OK', 'transport_thrusters',
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
            self._events.append(Event(t, 'WARN', 'grasp_released', f'the arm lets go at t = {t:.3f} s: '
                                                                    f'{result.release_reason}',
                                      dict(t=t, reason=result.release_reason, **peaks)))
            return
        props = self._lock(chaser_b, target_b)
        displacement, rotation = self._arm_deflection(result.bodies_at(0), (chaser_b, target_b))
        self._events.append(Event(t, 'OK', 'grasp_damped', f'the arm locks at t = {t:.3f} s: one rigid body of '
                                                            f'{props.mass_kg:.2f} kg',
                                  dict(t=t, damping_time_s=float(result.t_s[k]), arm_displacement_body_m=displacement,
                                       arm_rotation_body_rad=rotation, **peaks)))

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
        self._body = combined
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

    def _rigid_truth_and_samples(self, body):
        imu = self._imu_measurement(body)  # before the truth, which holds the gyro bias of this sample
        self._last = self._truth_rigid(body.totals, body)
        self._sample(self._last)
        if imu is not None:
            self._measurements.append(imu)
        return self._last

    def step(self):
        """Advance exactly one step_s; returns the TruthSample at the new time."""
        if self._mode == 'grasp':
            return self._step_grasp()
        if self._mode == 'combined':
            return self._step_combined()
        if self._mode == 'released':
            return self._step_released()
        if self.captured:
            return self._step_attached()
        if self._chaser is not None:
            return self._step_rigid()
        thrusters = self._thrusters
        t = self.t
        self._step_index += 1
        t1 = self.t
        y = self._y
        impulse = [0.0, 0.0, 0.0]
        firing = False
        while t < t1:
            burn = thrusters.active
            if burn is None:
                upcoming = thrusters.next_burn
                if upcoming is None or upcoming.start_s > t:
                    t_end = t1 if upcoming is None else min(t1, upcoming.start_s)
                    y = rk4_step_floats(self._coast_rhs, t, y, t_end - t)
                    t = t_end
                    continue
                burn = self._start_burn(t)
            t_end = min(t1, burn.end_s)
            self._check_restriction(burn, t, y)
            y = rk4_step_floats(self._burn_rhs, t, y, t_end - t)
            mass_end = burn.mass_end_kg if t_end == burn.end_s else self._burn_mass(burn, t_end)
            self._dv_total_mps += thrusters.exhaust_velocity_mps * math.log(self._mass_kg / mass_end)
            force = self.config.thrusters.max_thrust_n * (t_end - t)
            for axis, u in enumerate(burn.direction_hill):
                impulse[axis] += force * u
            self._mass_kg = mass_end
            firing = True
            t = t_end
            self._check_restriction(burn, t, y)
            if t == burn.end_s:
                self._end_burn(t)
        self._y = y
        step_s = self.config.step_s
        self._last = self._truth(np.array(impulse) / step_s, firing)
        self._sample(self._last)
        return self._last

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

    def _step_rigid(self):
        chaser = self._chaser
        t = self.t
        self._step_index += 1
        chaser.advance(t, self.t)
        self._y = chaser.y_translation
        self._mass_kg = chaser.mass_kg
        self._dv_total_mps = chaser.dv_total_mps
        dv = chaser.totals.dv_thrust_hill
        for k in range(3):
            self._imu_dv_hill[k] += dv[k]
        return self._rigid_truth_and_samples(chaser)

    def _imu_measurement(self, chaser):
        """The chaser IMU's Measurement at the current step, or None between its samples (chaser: the rigid body
        integrated, whose attitude and rate are the chaser's)."""
        k = self._imu_schedule.sample_index(self._step_index)
        if k is None:
            return None
        t = self.t
        # The accelerometer's velocity increment over the sample interval (the thrust acceleration integrated in
        # hill axes, resolved in chaser_body at the sample; hill turns from inertial by n dt ~ 1e-4 rad over an
        # interval, left out) over the interval: the mean specific force since the previous sample, so a firing
        # shorter than the interval is sensed in full (sensors module doc).
        q_body_from_hill = quat_conjugate(chaser.q_hill_from_body(t))
        specific_force = quat_rotate(q_body_from_hill, self._imu_dv_hill) / (t - self._imu_t_last)
        if self._mode == 'combined':  # at the chaser's CoM, p = -c from the combined one: omega_dot x p (its
            # interval mean, exactly) + omega x (omega x p) (seed 004 section 2.2, combined_body.specific_force_body)
            omega, p = chaser.omega_body, -self._com_body
            if self._imu_omega_last is not None:
                specific_force = specific_force + np.cross((omega - self._imu_omega_last) / (t - self._imu_t_last), p)
            specific_force = specific_force + np.cross(omega, np.cross(omega, p))
            self._imu_omega_last = omega
        self._imu_dv_hill = [0.0, 0.0, 0.0]
        self._imu_t_last = t
        # The star tracker reads at samples k = 1, 1 + every, 1 + 2 every, ...: the first IMU sample carries one,
        # so the estimator gives a chaser estimate from the first IMU stamp on.
        star_tracker = (k - 1) % self._star_tracker_every == 0
        return Measurement('chaser_imu', t, self._imu.sample(t, star_tracker,
                                                             chaser.q_hill_from_body(t), chaser.omega_body,
                                                             specific_force))

    def _truth_rigid(self, totals, chaser=None):
        """The TruthSample of the six-degree-of-freedom chaser at the current time (chaser: the rigid body integrated,
        the chaser's own by default)."""
        chaser = self._chaser if chaser is None else chaser
        r_target = v_target = None
        if self._target_now is None:
            q_hill_from_body, omega_body = self._target_attitude()
        else:
            q_hill_from_body, omega_body, r_target, v_target = self._target_now
        torque_body, torque_hill = totals.torque_body_n_m, totals.torque_hill_n_m
        if chaser is not self._chaser:  # the combined body's torque is about its CoM: the contract's is about the
            # chaser's, T_c = T + c x F
            torque_body = torque_body + np.cross(self._com_body, totals.force_body_n)
            torque_hill = torque_hill + np.cross(quat_rotate(chaser.q_hill_from_body(self.t), self._com_body),
                                                 totals.force_hill)
        y = self._y
        omega_chaser = chaser.omega_body
        h = chaser.h_wheels_n_m_s
        return TruthSample(t=self.t, r_hill=np.array(y[:3]), v_hill=np.array(y[3:]),
                           q_hill_from_body=q_hill_from_body, omega_body=omega_body, force_hill=totals.force_hill,
                           mass_kg=self._mass_kg, fuel_used_kg=self.config.chaser_mass_kg - self._mass_kg,
                           dv_applied_total_mps=self._dv_total_mps, firing=totals.firing,
                           q_hill_from_chaser_body=chaser.q_hill_from_body(self.t), omega_chaser_body=omega_chaser,
                           wheel_momentum_n_m_s=h, wheel_speed_rad_s=chaser.wheel_speeds_rad_s(),
                           wheel_torque_n_m=totals.wheel_torque_n_m, force_body_n=totals.force_body_n,
                           torque_body_n_m=torque_body, torque_hill_n_m=torque_hill,
                           thruster_thrust_n=totals.thruster_thrust_n, gyro_bias_rad_s=self._imu.gyro_bias_rad_s,
                           r_target_hill=r_target, v_target_hill=v_target)

    def _coast_rhs(self, t, y):
        return (y[3], y[4], y[5], *self._accel(y[:3], y[3:], _ZERO3))

    def _burn_mass(self, burn, t):
        return burn.mass_start_kg - self._thrusters.mass_flow_kg_s * (t - burn.start_s)

    def _start_burn(self, t):
        burn = self._thrusters.start_next()
        thrust_n = self.config.thrusters.max_thrust_n
        ux, uy, uz = burn.direction_hill

        def burn_rhs(tau, y):
            k = thrust_n / self._burn_mass(burn, tau)  # F / m(t), mass falling linearly
            return (y[3], y[4], y[5], *self._accel(y[:3], y[3:], (k * ux, k * uy, k * uz)))

        self._burn_rhs = burn_rhs
        self._restriction_reported = False
        self._events.append(Event(self.t, 'OK', 'burn_started', f'burn {burn.seq} started at t = {t:.3f} s',
                                  dict(seq=burn.seq, t_cmd=burn.t_cmd_s, t_start=burn.start_s,
                                          t_end=burn.end_s, dv_cmd_hill=burn.dv_cmd_hill,
                                          dv_hill=burn.dv_hill, mass_kg=burn.mass_start_kg)))
        if burn.late:
            lateness = burn.start_s - burn.t_cmd_s
            self._events.append(Event(self.t, 'WARN', 'late_maneuver',
                                      f'burn {burn.seq} stamped {burn.t_cmd_s:.3f} s started {lateness:.3f} s late',
                                      dict(seq=burn.seq, t_cmd=burn.t_cmd_s, t_start=burn.start_s,
                                              lateness_s=lateness)))
        return burn

    def _end_burn(self, t):
        burn = self._thrusters.finish_active()
        self._burn_rhs = None
        self._events.append(Event(self.t, 'OK', 'burn_ended', f'burn {burn.seq} ended at t = {t:.3f} s',
                                  dict(seq=burn.seq, t_end=t, dv_hill=burn.dv_hill, fuel_kg=burn.fuel_kg,
                                          mass_kg=burn.mass_end_kg)))

    def _check_restriction(self, burn, t, y):
        """Record (once per burn) thrust applied inside the thruster-restriction sphere."""
        x, yy, z = y[:3]
        range_m = math.sqrt(x * x + yy * yy + z * z)
        radius_m = self.config.restriction_sphere_radius_m
        if range_m < radius_m and not self._restriction_reported:
            self._restriction_reported = True
            self._events.append(Event(self.t, 'ERROR', 'thrust_inside_restriction_sphere',
                                      f'burn {burn.seq} thrusts at {range_m:.3f} m, inside the '
                                      f'{radius_m:.3f} m restriction sphere',
                                      dict(seq=burn.seq, t=t, range_m=range_m,
                                              restriction_sphere_radius_m=radius_m)))

    def _target_attitude(self):
        """(q_hill_from_body, omega_body) at the current step, from the chunk of steps evaluated at once."""
        first, q_rows, omega_rows = self._attitude_chunk
        i = self._step_index - first
        if i >= len(q_rows):
            step_s = self.config.step_s
            first = self._step_index
            t_s = [k * step_s for k in range(first, first + ATTITUDE_CHUNK_STEPS)]  # as self.t, to the bit
            q_eci_from_body, omega_body = self._attitude.states_at(t_s)
            q_rows = list(q_hill_from_body_many(t_s, self.mean_motion_rad_s, q_eci_from_body))
            omega_rows = list(omega_body)
            self._attitude_chunk = (first, q_rows, omega_rows)
            i = 0
        return q_rows[i], omega_rows[i]

    def _truth(self, force_hill, firing):
        q_hill_from_body, omega_body = self._target_attitude()
        y = self._y
        return TruthSample(t=self.t, r_hill=np.array(y[:3]), v_hill=np.array(y[3:]),
                           q_hill_from_body=q_hill_from_body, omega_body=omega_body, force_hill=force_hill,
                           mass_kg=self._mass_kg, fuel_used_kg=self.config.chaser_mass_kg - self._mass_kg,
                           dv_applied_total_mps=self._dv_total_mps, firing=firing)

    def _sample(self, truth):
        self._measurements = []
        if self._position_schedule.is_sample_step(self._step_index):
            self._measurements.append(Measurement('relative_position', truth.t,
                                                  self._sensors.relative_position(truth.r_hill)))
        if self._attitude_schedule.is_sample_step(self._step_index):
            self._measurements.append(Measurement('target_attitude', truth.t,
                                                  self._sensors.target_attitude(truth.q_hill_from_body)))


def plant_config_from_scenario(scenario):
    """The plant configuration of a validated scenario (``flyby_sim.scenario.Scenario``)."""
    sc = scenario
    th = sc.chaser.thrusters
    return PlantConfig(
        radius_m=sc.orbit_radius_m,
        mu=sc.orbit.mu_m3_s2,
        chaser_mass_kg=sc.chaser.mass_kg,
        r0_hill=tuple(sc.chaser.initial_position_hill_m),
        v0_hill=tuple(sc.chaser.initial_velocity_hill_mps),
        target_inertia=tuple(map(tuple, sc.target_inertia)),
        q_hill_from_body0=tuple(sc.q_hill_from_body0),
        omega_body0=tuple(sc.omega_body0_rad_s),
        thrusters=ThrusterConfig(
            max_thrust_n=th.max_thrust_n, isp_s=th.isp_s,
            min_impulse_bit_ns=th.min_impulse_bit_ns,
            max_delta_v_per_maneuver_mps=th.max_delta_v_per_maneuver_mps,
            magnitude_error_sigma=th.magnitude_error_sigma,
            direction_error_sigma_rad=math.radians(th.direction_error_sigma_deg)),
        dynamics=sc.simulation.dynamics,
        step_s=sc.simulation.step_s,
        position_sigma_m=sc.sensors.relative_position.noise_sigma_m,
        position_rate_hz=sc.sensors.relative_position.rate_hz,
        attitude_sigma_rad=math.radians(sc.sensors.target_attitude.noise_sigma_deg),
        attitude_rate_hz=sc.sensors.target_attitude.rate_hz,
        restriction_sphere_radius_m=sc.planner.restriction_sphere_radius_m,
        seed=sc.seed,
        chaser_body=rigid_chaser_config_from_scenario(sc) if sc.chaser.model == 'rigid_body' else None,
        grasp=None if sc.post_capture is None else grasp_config_from_scenario(sc),
    )


def grasp_config_from_scenario(scenario):
    """The GraspConfig of a validated scenario with a post_capture section."""
    pc = scenario.post_capture
    g = pc.grasp
    attachment = pc.attachment
    return GraspConfig(scenario.arm_impedance, scenario.target.mass_kg, tuple(scenario.target.grasp_point_body_m),
                       g.velocity_tolerance_mps, g.rate_tolerance_rad_s, g.max_duration_s,
                       None if attachment is None else tuple(attachment.target_com_chaser_body_m),
                       None if attachment is None else tuple(scenario.q_chaser_from_target_attached),
                       None if pc.transport is None else pc.transport.plume_cone_deg)


def rigid_chaser_config_from_scenario(scenario):
    """The RigidChaserConfig of a validated scenario's chaser (its rigid-body keys, whatever chaser.model says)."""
    sc = scenario
    chaser = sc.chaser
    layout = chaser.thrusters.layout
    wheels = chaser.wheels
    imu = sc.sensors.chaser_imu
    return RigidChaserConfig(
        inertia=tuple(map(tuple, sc.chaser_inertia.tolist())),
        q_hill_from_body0=tuple(sc.q_hill_from_chaser_body0.tolist()),
        omega_body0=tuple(sc.omega_chaser_body0_rad_s.tolist()),
        thruster_positions_body_m=None if layout is None else tuple(tuple(x.position_m.tolist()) for x in layout),
        thruster_directions_body=None if layout is None else tuple(tuple(x.direction.tolist()) for x in layout),
        wheel_axes_body=tuple(map(tuple, wheels.axes.tolist())),
        wheel_max_torque_n_m=wheels.max_torque_n_m,
        wheel_max_momentum_n_m_s=wheels.max_momentum_n_m_s,
        wheel_spin_inertia_kg_m2=wheels.spin_inertia_kg_m2,
        wheel_momentum0_n_m_s=None if wheels.initial_momentum_n_m_s is None else tuple(
            wheels.initial_momentum_n_m_s.tolist()),
        imu=ImuConfig(rate_hz=imu.rate_hz, star_tracker_rate_hz=imu.star_tracker_rate_hz,
                      star_tracker_sigma_rad=math.radians(imu.star_tracker_sigma_deg),
                      gyro_noise_sigma_rad_s=imu.gyro_noise_sigma_rad_s,
                      gyro_bias_sigma_rad_s=imu.gyro_bias_sigma_rad_s,
                      gyro_bias_walk_rad_s_sqrt_s=imu.gyro_bias_walk_rad_s_sqrt_s,
                      accel_noise_sigma_mps2=imu.accel_noise_sigma_mps2),
    )
