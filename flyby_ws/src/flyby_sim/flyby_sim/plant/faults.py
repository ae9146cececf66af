"""``FaultInjection``: the plant's part of the scenario's faults (``flyby_sim.faults``; docs/faults.md).

At the start of every step the faults due begin or end (``fault_injected``, WARN; ``fault_ended``, OK; both from
the simulator, the record's and the summary's, not the flight software's): a thruster or wheel fault changes the
body's ``Health`` (the chaser's, and the combined body's after the lock), a gyro bias jump steps the IMU's bias, and a
sensor fault drops or spoils the samples of its sensor taken while it acts.
"""

import math

import numpy as np

from flyby_msgs_py import events
from flyby_msgs_py.event_payloads import FaultEnded, FaultInjected, encode
from flyby_msgs_py.wire import Event
from flyby_sim.chaser_body.health import Health
from flyby_sim.dynamics.propulsion import ManeuverRejected
from flyby_sim.dynamics.rotation import quat_from_rotation_vector, quat_multiply, quat_normalize
from flyby_sim.faults import SENSOR_KINDS, THRUSTER_KINDS, WHEEL_KINDS, FaultSchedule, random_unit
from flyby_sim.plant.config import Measurement


class FaultInjection:
    """Mixin of ``Plant``: the fault schedule, its events, the hardware's health and the sensors' faults."""

    _isolated = frozenset()  # before _init_faults (a run that starts attached locks in the constructor)
    _t_cam = None  # before _init_faults (the chaser body reports events from its constructor on)

    def _init_faults(self, rng):
        """The schedule of config.faults on rng (the fault stream of the scenario's seed)."""
        self._faults = FaultSchedule(self.config.faults, rng)
        self._fault_effect = {}  # index -> what it drew at its start (a turn, a bias step)
        self._isolated = set()  # thrusters whose valves the supervisor closed (isolate_thrusters)
        self._t_cam = None  # the stamp of the independent monitor's CAM (command_cam)
        self._cam_seq = None  # its burn's sequence number (the six-degree-of-freedom chaser's)
        self._cam_ignored = set()

    def on_phase(self, phase, t_stamp):
        """The supervisor's phase began at its transition's stamp t_stamp [s] (the faults that start with it are due
        from then on; one that arrives late starts at once)."""
        self._faults.on_phase(phase, t_stamp)

    def command_cam(self, t_stamp, dv_hill):
        """The independent monitor's collision-avoidance manoeuvre (safety/cam): every command queued and the burn
        under way dropped, the CAM's burn from its stamp; from then on the planning chain's maneuvers and wrench
        commands are ignored (``cam_lockout``; its wheel commands still hold the attitude). Once; not after a
        capture."""
        if self.captured or self._t_cam is not None:
            return
        self._thrusters.cancel_all()
        self._burn_rhs = None
        if self._chaser is not None:
            self._chaser.cancel_thrust()
        try:
            request = self.command_maneuver(t_stamp, dv_hill, full_thrust=True)
        except ManeuverRejected:
            return  # recorded (maneuver_rejected): no CAM, the chain keeps the thrusters
        self._cam_seq = getattr(request, 'seq', None)
        self._t_cam = float(t_stamp)
        self._events.append(Event(self.t, 'WARN', events.CAM_EXECUTED,
                                  f'CAM of {float(np.linalg.norm(dv_hill)):.4g} m/s stamped {t_stamp:.3f} s: the '
                                  f'planning chain\'s thrust commands are ignored from now on',
                                  dict(t_stamp=float(t_stamp), dv_hill=np.asarray(dv_hill, dtype=float))))

    def _cam_not_flown(self, event):
        """The CAM's burn refused when it was to start (the thrusters left by an isolation give no pure force along
        it): the planning chain keeps the thrusters, as for a CAM refused when commanded."""
        if (event.name == events.MANEUVER_REJECTED and self._t_cam is not None
                and event.values.get('seq') == self._cam_seq):
            self._t_cam = None

    def cam_lockout(self, kind, t_stamp):
        """True for a planning chain's thrust command after the CAM (a command_ignored event, the first of each
        kind)."""
        if self._t_cam is None:
            return False
        if kind not in self._cam_ignored:
            self._cam_ignored.add(kind)
            self._events.append(Event(self.t, 'WARN', events.COMMAND_IGNORED,
                                      f'{kind} command stamped {t_stamp} s ignored: the CAM has the thrusters (and '
                                      f'the later ones of its kind)', dict(command=kind, t_stamp=t_stamp)))
        return True

    def isolate_thrusters(self, indices):
        """Close the valves of these thrusters (a fault table's response, ``thrusters_isolated``): from now on they
        give nothing, a leak included, and wrench commands and burns are allocated without them."""
        if self._chaser is None:
            return
        new = {int(i) for i in indices if 0 <= int(i) < self._chaser.layout.count} - self._isolated
        if not new:
            return
        self._isolated |= new
        self._apply_health()
        self._restrict()
        self._events.append(Event(self.t, 'WARN', events.THRUSTERS_CLOSED,
                                  f'thrusters {sorted(new)} closed (isolated: {sorted(self._isolated)})',
                                  dict(thrusters=sorted(self._isolated))))

    def _restrict(self):
        """The bodies' allocation on the thrusters allowed: not isolated, and in TRANSPORT not aimed at the target."""
        allowed = np.ones(self._chaser.layout.count, dtype=bool) if self._transport_mask is None \
            else self._transport_mask.copy()
        allowed[sorted(self._isolated)] = False
        if not allowed.any():  # every thruster closed: nothing fires (their health gives nothing)
            self._events.append(Event(self.t, 'ERROR', events.THRUSTERS_CLOSED, 'every thruster allowed is closed: '
                                      'no thrust is left', dict(thrusters=sorted(self._isolated))))
            return
        for body in self._bodies():
            body.restrict_thrusters(allowed)

    def _bodies(self):
        """The chaser and, after the lock, the combined body the plant integrates (each once)."""
        return [self._chaser] if self._body is self._chaser else [self._chaser, self._body]

    def _apply_health(self):
        health = self._health()
        for body in self._bodies():
            body.set_health(health)

    def _inject_due(self):
        """Begin and end the faults due at the current time, before the step integrates."""
        started, ended = self._faults.due(self.t)
        if not started and not ended:
            return
        hardware = False
        for i in ended:
            hardware |= self._end_fault(i)
        for i in started:
            hardware |= self._start_fault(i)
        if hardware:
            self._apply_health()

    def _start_fault(self, i):
        spec = self._faults.specs[i]
        if spec.kind == 'thruster_misaligned':
            direction = self._chaser.errors.force_directions_body[spec.index]
            self._fault_effect[i] = math.radians(spec.magnitude) * self._faults.axis(i, across=direction)
        elif spec.kind == 'gyro_bias_jump':
            step = spec.magnitude * self._faults.axis(i)
            self._fault_effect[i] = step
            self._imu.step_bias(step)
        until = 'to the run\'s end' if spec.duration_s is None else f'for {spec.duration_s:g} s'
        how = '' if spec.magnitude is None else f' ({spec.magnitude:g})'
        self._events.append(Event(self.t, 'WARN', events.FAULT_INJECTED,
                                  f'fault {i} injected: {spec.kind} on {spec.target}{how} {until}',
                                  encode(FaultInjected(i, spec.kind, spec.target, self.t, spec.duration_s,
                                                       spec.magnitude))))
        if spec.duration_s == 0.0:
            self._end_fault(i)
        return spec.kind in THRUSTER_KINDS + WHEEL_KINDS and spec.duration_s != 0.0

    def _end_fault(self, i):
        spec = self._faults.specs[i]
        if spec.kind == 'gyro_bias_jump' and i in self._fault_effect:
            self._imu.step_bias(-self._fault_effect[i])
        self._fault_effect.pop(i, None)
        self._events.append(Event(self.t, 'OK', events.FAULT_ENDED, f'fault {i} ended: {spec.kind} on '
                                                                       f'{spec.target}',
                                  encode(FaultEnded(i, spec.kind, spec.target, self.t))))
        return spec.kind in THRUSTER_KINDS + WHEEL_KINDS

    def _health(self):
        """The thrusters' and wheels' Health under the hardware faults acting now."""
        layout = self._chaser.layout
        gain, leak = [1.0] * layout.count, [0.0] * layout.count
        turn = [np.zeros(3) for _ in range(layout.count)]
        wheel = [1.0] * self._chaser.wheels.count
        for i in self._faults.active:
            spec = self._faults.specs[i]
            k = spec.index
            if spec.kind == 'thruster_off':
                gain[k] = 0.0
            elif spec.kind == 'thruster_degraded':
                gain[k] *= spec.magnitude
            elif spec.kind == 'thruster_stuck_on':
                leak[k] = max(leak[k], spec.magnitude * float(layout.max_thrust_n[k]))
            elif spec.kind == 'thruster_misaligned':
                turn[k] = turn[k] + self._fault_effect[i]
            elif spec.kind == 'wheel_failed':
                wheel[k] = 0.0
            elif spec.kind == 'wheel_torque_limited':
                wheel[k] *= spec.magnitude
        for k in self._isolated:
            gain[k], leak[k] = 0.0, 0.0
        return Health(tuple(gain), tuple(leak), tuple(tuple(x.tolist()) for x in turn), tuple(wheel))

    def _sensor_faults(self, measurements):
        """The samples as the faulted sensors give them: dropped, or off by an outlier (module doc)."""
        if not any(self._faults.specs[i].kind in SENSOR_KINDS for i in self._faults.active):
            return measurements
        out = []
        for m in measurements:
            if m.kind == 'chaser_imu':
                m = self._imu_faults(m)
            elif self._faults.sensor_fault('sensor_dropout', m.kind) is not None:
                m = None
            else:
                i = self._faults.sensor_fault('sensor_outliers', m.kind)
                if i is not None:
                    m = self._outlier(i, m)
            if m is not None:
                out.append(m)
        return out

    def _outlier(self, i, m):
        """Sample m of relative_position or target_attitude off by fault i's value times its sensor's sigma."""
        rng, value = self._faults.rng(i), self._faults.specs[i].magnitude
        direction = random_unit(rng)
        if m.kind == 'relative_position':
            return m._replace(value=m.value + value * self.config.position_sigma_m * direction)
        turn = quat_from_rotation_vector(value * self.config.attitude_sigma_rad * direction)
        return m._replace(value=quat_normalize(quat_multiply(m.value, turn)))

    def _imu_faults(self, m):
        """The IMU's sample under its faults: none (imu dropout), without its star-tracker attitude, or off."""
        schedule, sample = self._faults, m.value
        if schedule.sensor_fault('sensor_dropout', 'imu') is not None:
            return None
        if sample.q_hill_from_body is not None and schedule.sensor_fault('sensor_dropout', 'star_tracker') is not None:
            sample = sample._replace(q_hill_from_body=None)
        i = schedule.sensor_fault('sensor_outliers', 'imu')
        if i is not None:
            rng, value, imu = schedule.rng(i), schedule.specs[i].magnitude, self._imu
            sample = sample._replace(
                omega_body_meas=sample.omega_body_meas + value * imu.gyro_noise_sigma_rad_s * random_unit(rng),
                specific_force_body=sample.specific_force_body + value * imu.accel_noise_sigma_mps2 * random_unit(rng))
        i = schedule.sensor_fault('sensor_outliers', 'star_tracker')
        if i is not None and sample.q_hill_from_body is not None:
            turn = quat_from_rotation_vector(schedule.specs[i].magnitude * self._imu.star_tracker_sigma_rad
                                           * random_unit(schedule.rng(i)))
            sample = sample._replace(q_hill_from_body=quat_normalize(quat_multiply(sample.q_hill_from_body, turn)))
        return Measurement(m.kind, m.t, sample)

