"""``Plant``: the truth simulation's state, its commands, the step and what it reports (truth, sensors, events).

The point-mass chaser's finite burns are ``plant.point_mass``, the phases from the capture on ``plant.capture``
(package doc).
"""


import numpy as np

from flyby_msgs_py import events
from flyby_msgs_py.wire import Event
from flyby_sim.chaser_body import SixDofChaser
from flyby_sim.dynamics.attitude import AttitudePropagator
from flyby_sim.dynamics.orbital import (
    mean_motion_rad_s,
    q_eci_from_body,
    q_hill_from_body_many,
    relative_accel_components,
)
from flyby_sim.dynamics.propulsion import ManeuverRejected
from flyby_sim.dynamics.rotation import quat_conjugate, quat_normalize, quat_rotate
from flyby_sim.dynamics.sampling import SampleSchedule
from flyby_sim.plant.capture import CapturePhases
from flyby_sim.plant.config import Measurement, PlantConfig, TruthSample
from flyby_sim.plant.faults import FaultInjection
from flyby_sim.plant.point_mass import PointMassFlight
from flyby_sim.sensors import ImuModel, SensorModel
from flyby_sim.thrusters import ThrusterModel

_ZERO3 = (0.0, 0.0, 0.0)
ATTITUDE_CHUNK_STEPS = 100  # steps of target attitude evaluated at once (5 s at 20 Hz)


class Plant(PointMassFlight, CapturePhases, FaultInjection):
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

    def __init__(self, config: PlantConfig):
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
        self._init_faults(np.random.default_rng(root_seed.spawn(1)[0]))  # after the other streams: theirs unchanged
        if self._chaser is not None:  # the wheels' tachometers, after the faults' stream
            self._tachometer_rng = np.random.default_rng(root_seed.spawn(1)[0])

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
        self._cam_not_flown(event)

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

    def command_maneuver(self, t_stamp, dv_hill, full_thrust=False):
        """Schedule an impulsive delta-v dv_hill [m/s] to start at sim time t_stamp [s].

        Returns the thrusters.Burn as scheduled now (start_s, end_s, late, dv_hill to be delivered); for the
        six-degree-of-freedom chaser a chaser_body.ManeuverRequest (the burn's direction and duration are fixed
        when it starts, at the attitude then: the burn_started event).
        Raises ManeuverRejected (and records an ERROR event) for an unexecutable command.
        """
        if self.cam_lockout('maneuver', t_stamp):
            return None
        try:
            if self.captured:
                raise ManeuverRejected(f'the chaser is attached to the target; maneuver stamped {t_stamp} s dropped')
            if self._chaser is not None:
                return self._chaser.command_maneuver(self.t, t_stamp, dv_hill, full_thrust)
            return self._thrusters.schedule(t_stamp, dv_hill, self.t, self._mass_kg)
        except ManeuverRejected as exc:
            self._events.append(Event(self.t, 'ERROR', events.MANEUVER_REJECTED, exc.reason,
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
        if self.cam_lockout('wrench', t_stamp):
            return None
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
        self._events.append(Event(self.t, 'WARN', events.COMMAND_IGNORED,
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

    def _rigid_truth_and_samples(self, body):
        imu = self._imu_measurement(body)  # before the truth, which holds the gyro bias of this sample
        self._last = self._truth_rigid(body.totals, body)
        self._sample(self._last)
        if imu is not None:
            self._measurements += [imu, self._wheel_speeds(imu.t, body)]
        return self._last

    def _wheel_speeds(self, t, body):
        """The wheels' tachometers with the IMU's sample: each wheel's spin rate relative to the chaser [rad/s], with
        its noise (chaser.wheels.tachometer_sigma_rad_s)."""
        sigma = self.config.chaser_body.wheel_tachometer_sigma_rad_s
        speeds = body.wheel_speeds_rad_s()
        return Measurement('wheel_speeds', t, speeds + sigma * self._tachometer_rng.standard_normal(speeds.size))

    def step(self):
        """Advance exactly one step_s; returns the TruthSample at the new time."""
        self._inject_due()
        if self._mode == 'grasp':
            s = self._step_grasp()
        elif self._mode == 'combined':
            s = self._step_combined()
        elif self._mode == 'released':
            s = self._step_released()
        elif self.captured:
            s = self._step_attached()
        elif self._chaser is not None:
            s = self._step_rigid()
        else:
            s = self._step_point_mass()
        self._measurements = self._sensor_faults(self._measurements)
        return s

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
