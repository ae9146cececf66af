"""``SixDofChaser``: the rigid-body chaser's state, command queues and integration (package doc)."""

import math

import numpy as np

from flyby_msgs_py import events
from flyby_msgs_py.wire import Event
from flyby_sim.chaser_body.config import MAX_SUBSTEP_ANGLE_RAD
from flyby_sim.chaser_body.health import Health
from flyby_sim.chaser_body.records import ManeuverRequest, StepTotals, ThrusterBurn, WheelCommand, WrenchCommand
from flyby_sim.dynamics.actuators import allocate_wrench, draw_thruster_errors, fire, plan_burn, wrench_matrix
from flyby_sim.dynamics.checks import finite_vector
from flyby_sim.dynamics.orbital import q_eci_from_body, q_hill_from_body, rk4_step_floats
from flyby_sim.dynamics.propulsion import ManeuverRejected, check_delta_v
from flyby_sim.dynamics.rigid_body import gyrostat_rates_floats, substep_count
from flyby_sim.dynamics.rotation import quat_conjugate, quat_normalize, quat_rotate

_ZERO3 = (0.0, 0.0, 0.0)


def _sort_key(command):
    return command.t_apply, command.t_stamp, command.seq


class SixDofChaser:
    """The rigid-body chaser's state, commands and integration (module doc); driven by ``Plant``."""

    def __init__(self, config, thrusters, r0_hill, v0_hill, mass_kg, mean_motion_rad_s, accel, step_s,
                 restriction_sphere_radius_m, rng_errors, emit, errors=None, com_body_m=(0.0, 0.0, 0.0)):
        """config: RigidChaserConfig; thrusters: propulsion.ThrusterConfig; accel(r, v, a_ext): the relative
        acceleration on floats (``orbital.*_accel_components``); rng_errors: the Generator of the thruster
        errors (4 N draws, here), unless errors (``actuators.ThrusterErrors``, the hardware's, drawn before) is
        given; emit(Event) records an event.

        com_body_m: the centre of mass the body turns about, from the chaser's own CoM [m, chaser_body]: nonzero
        for the combined body of chaser and captured target (seed 004 section 2.2), whose config, mass and
        translation are the combined body's. The thrusters then act at their true positions about it (the
        moment about the combined CoM is T - c x F), while wrench commands stay about the chaser's CoM
        (DESIGN §10 /guidance/wrench) and are allocated on the layout as before."""
        self.config = config
        self.thrusters = thrusters
        self.layout = config.layout(thrusters)
        self.wheels = config.wheels()
        self.step_s = step_s
        self._n = mean_motion_rad_s
        self._accel = accel
        self._radius_m = restriction_sphere_radius_m
        self._emit = emit
        self._ve = self.layout.exhaust_velocity_mps
        self.errors = errors if errors is not None else draw_thruster_errors(
            self.layout, rng_errors, thrusters.magnitude_error_sigma, thrusters.direction_error_sigma_rad)
        self._com_body_m = np.asarray(com_body_m, dtype=float)
        self.health = Health.nominal(self.layout.count, config.wheels().count)
        self._set_actual_columns()
        self._factors = tuple(self.errors.magnitude_factors.tolist())
        self._max_thrust = tuple(self.layout.max_thrust_n.tolist())
        inertia = np.array(config.inertia)
        self._inertia = config.inertia
        self._inertia_inv = tuple(map(tuple, np.linalg.inv(inertia).tolist()))
        self._inertia_min = float(np.linalg.eigvalsh(inertia)[0])
        self._axes = tuple(map(tuple, self.wheels.axes_body.tolist()))
        self._h_max = tuple(self.wheels.max_momentum_n_m_s.tolist())
        self._u_max = tuple(self.wheels.max_torque_n_m.tolist())
        self._spin_inertia = tuple(self.wheels.spin_inertia_kg_m2.tolist())
        nw = self.wheels.count
        self._nw = nw
        # state: translation (hill, as the point-mass chaser), attitude (ECI), wheels, mass
        self._y = list(r0_hill) + list(v0_hill)
        self._t_trans = 0.0
        q_eci0 = q_eci_from_body(0.0, mean_motion_rad_s, quat_normalize(config.q_hill_from_body0))
        h0 = config.wheel_momentum0_n_m_s
        self._att = q_eci0.tolist() + list(config.omega_body0) + [float(h) for h in h0]
        self.mass_kg = mass_kg
        self.dv_total_mps = 0.0
        # commands
        self._wrench_queue, self._wheel_queue, self._requests = [], [], []
        self._wrench = None  # WrenchCommand held
        self._wheel = None  # WheelCommand held
        self._burn = None  # ThrusterBurn in progress
        self._burn_dv_hill = [0.0, 0.0, 0.0]  # integral of the thrust acceleration (hill) while it burns
        self._last_burn_end = -math.inf
        self._seq = {'wrench': 0, 'wheels': 0, 'maneuver': 0}
        self._thrusts = (0.0,) * self.layout.count  # nominal thrusts now (burn + wrench, limited)
        self._actual = self._thrusts  # what the thrusters give for them (``health``)
        self._burn_share = (0.0,) * self.layout.count
        self._wrench_share = (0.0,) * self.layout.count
        self._reported = set()  # (event name, source...) reported once
        self._allocated = (None, None, None)  # the last wrench allocated: (force, torque, hold), Allocation, Firing
        self._allowed = None  # indices of the thrusters wrench commands may fire (None: all; restrict_thrusters)
        self._totals = self._zero_totals()

    def set_health(self, health):
        """From now on the thrusters and wheels act as ``health`` leaves them (injected faults, ``health``)."""
        self.health = health
        self._set_actual_columns()
        self._update_thrusts(None)

    def _set_actual_columns(self):
        """The wrench per unit nominal thrust of each thruster, its errors and its health's turn included."""
        b_actual = wrench_matrix(self.layout.positions_body_m - self._com_body_m,
                                 self.health.directions(self.errors.force_directions_body)) \
            * self.errors.magnitude_factors
        self._b_actual_columns = tuple(map(tuple, b_actual.T.tolist()))

    def restrict_thrusters(self, allowed):
        """From now on wrench commands are allocated on the thrusters where allowed ((N,) bool) is True only (a tug
        that must not fire at what it holds, seed 004 §2.3); a wrench they cannot give is reported undelivered."""
        allowed = np.asarray(allowed, dtype=bool)
        if allowed.shape != (self.layout.count,) or not allowed.any():
            raise ValueError(f'allowed must be {self.layout.count} booleans, at least one True, got {allowed!r}')
        self._allowed = (np.flatnonzero(allowed), self.layout.subset(allowed))
        self._allocated = (None, None, None)

    # -- state ------------------------------------------------------------------------------------
    @property
    def r_hill(self):
        return np.array(self._y[:3])

    @property
    def v_hill(self):
        return np.array(self._y[3:])

    @property
    def y_translation(self):
        """[r_hill; v_hill] as floats (after ``advance``, at the step's end)."""
        return self._y

    @property
    def q_eci_from_body(self):
        return np.array(self._att[:4])

    @property
    def omega_body(self):
        return np.array(self._att[4:7])

    @property
    def h_wheels_n_m_s(self):
        return np.array(self._att[7:])

    def q_hill_from_body(self, t):
        """The attitude of chaser_body in hill at t (the current time) (x, y, z, w): ``orbital.q_hill_from_body``."""
        return q_hill_from_body(t, self._n, self._att[:4])

    def wheel_speeds_rad_s(self):
        """Each wheel's spin rate relative to the body [rad/s]: ``ReactionWheels.speeds_rad_s``, on floats."""
        wx, wy, wz = self._att[4:7]
        return np.array([h / j - (ax * wx + ay * wy + az * wz) for (ax, ay, az), h, j in
                         zip(self._axes, self._att[7:], self._spin_inertia, strict=True)])

    def set_attitude(self, q_eci_from_body_, omega_body_):
        """Overwrite the attitude and rate (the chaser attached to the target moves with it)."""
        self._att[:7] = list(q_eci_from_body_) + list(omega_body_)

    def set_translation(self, y, t):
        self._y = list(y)
        self._t_trans = t

    @property
    def totals(self):
        """StepTotals of the last step."""
        return self._totals

    # -- commands ---------------------------------------------------------------------------------
    def command_wrench(self, t_now, t_stamp, force_body_n, torque_body_n_m, hold_s=None):
        """Accept a body wrench [N, N m about the CoM, chaser_body] held from t_stamp [s]; returns the
        WrenchCommand. hold_s: how long the controller means to hold it (its control period) [s], the interval
        over which a thruster must give the minimum impulse bit (default: one plant step). Raises ValueError for
        a non-finite stamp or wrench, or a hold_s not finite and > 0."""
        force = finite_vector('force_body_n', force_body_n, 3)
        torque = finite_vector('torque_body_n_m', torque_body_n_m, 3)
        hold_s = self.step_s if hold_s is None else float(hold_s)
        if not (math.isfinite(hold_s) and hold_s > 0.0):
            raise ValueError(f'hold_s must be finite and > 0, got {hold_s!r}')
        t_apply = self._t_apply('wrench', t_now, t_stamp)
        seq = self._next_seq('wrench')
        if any(force) or any(torque):
            key = (force, torque, hold_s)
            if self._allocated[0] != key:  # a command repeated (a held dumping torque): no new LP
                allocation = self._allocate(force, torque)
                held = fire(self.layout, allocation.thrusts_n, hold_s)  # the minimum impulse bit over the hold
                self._allocated = (key, allocation, held)
            _, allocation, held = self._allocated
            thrusts = held.thrusts_n
            below = held.below_minimum_impulse
        else:
            allocation, thrusts, below = None, np.zeros(self.layout.count), np.zeros(self.layout.count, bool)
        commanded = np.array(force + torque)
        undelivered = commanded - self.layout.wrench_matrix @ thrusts
        command = WrenchCommand(seq, float(t_stamp), t_apply, force, torque, tuple(thrusts.tolist()),
                                tuple(undelivered.tolist()))
        if (allocation is not None and allocation.saturated) or below.any():
            why = 'beyond the thrusters' if allocation.saturated else 'below the minimum impulse bit'
            self._emit(Event(t_now, 'WARN', events.WRENCH_UNDELIVERED,
                             f'wrench command {seq} stamped {t_stamp:.3f} s: part {why} not delivered '
                             f'(force {np.linalg.norm(undelivered[:3]):.4g} N, torque '
                             f'{np.linalg.norm(undelivered[3:]):.4g} N m)',
                             dict(seq=seq, t_stamp=float(t_stamp), force_body_n=commanded[:3],
                                  torque_body_n_m=commanded[3:], undelivered_force_body_n=undelivered[:3],
                                  undelivered_torque_body_n_m=undelivered[3:], saturated=bool(
                                      allocation.saturated), below_minimum_impulse=np.flatnonzero(below))))
        self._wrench_queue = sorted([*self._wrench_queue, command], key=_sort_key)
        return command

    def _allocate(self, force, torque):
        """allocate_wrench on every thruster, or on the allowed ones (their thrusts put back in the layout's order)."""
        if self._allowed is None:
            return allocate_wrench(self.layout, force, torque)
        idx, sub = self._allowed
        allocation = allocate_wrench(sub, force, torque)
        thrusts = np.zeros(self.layout.count)
        thrusts[idx] = allocation.thrusts_n
        return allocation._replace(thrusts_n=thrusts)

    def command_wheels(self, t_now, t_stamp, torque_n_m):
        """Accept wheel motor torques [N m], one per wheel, held from t_stamp [s]; returns the WheelCommand
        (torques clipped to the limit, reported). Raises ValueError for a non-finite stamp or torque."""
        torque = finite_vector('torque_n_m', torque_n_m, self._nw)
        t_apply = self._t_apply('wheels', t_now, t_stamp)
        seq = self._next_seq('wheels')
        clipped = tuple(min(max(u, -u_max), u_max) for u, u_max in zip(torque, self._u_max, strict=True))
        if clipped != torque:
            limited = [i for i, (a, b) in enumerate(zip(torque, clipped, strict=True)) if a != b]
            self._emit(Event(t_now, 'WARN', events.WHEEL_TORQUE_LIMITED,
                             f'wheel command {seq} stamped {t_stamp:.3f} s exceeds the torque limit on wheels '
                             f'{limited}', dict(seq=seq, t_stamp=float(t_stamp), torque_commanded_n_m=torque,
                                                torque_n_m=clipped, wheels=limited)))
        command = WheelCommand(seq, float(t_stamp), t_apply, torque, clipped)
        self._wheel_queue = sorted([*self._wheel_queue, command], key=_sort_key)
        return command

    def command_maneuver(self, t_now, t_stamp, dv_hill, full_thrust=False):
        """Accept an impulsive delta-v [m/s, hill] to be burnt from t_stamp [s]; returns its ManeuverRequest.
        full_thrust: with the layout's largest force along it (a CAM). Raises ManeuverRejected (not recorded here)
        for a non-finite stamp or an unexecutable delta-v."""
        if not math.isfinite(t_stamp):
            raise ManeuverRejected(f'maneuver stamp t_cmd = {t_stamp} is not finite')
        dv = check_delta_v(dv_hill, self.mass_kg, self.thrusters)
        request = ManeuverRequest(self._next_seq('maneuver'), float(t_stamp), max(float(t_stamp), t_now),
                                  tuple(dv.tolist()), full_thrust)
        self._requests = sorted([*self._requests, request], key=lambda r: (r.request_s, r.seq))
        return request

    def cancel_thrust(self):
        """Drop every held and pending wrench and maneuver and the burn; the wheel command holds (a CAM)."""
        self._wrench_queue, self._requests = [], []
        self._wrench = self._burn = None
        self._update_thrusts(None)

    def cancel_all(self):
        """Drop every held and pending command and the burn (the chaser was captured)."""
        self._wrench_queue, self._wheel_queue, self._requests = [], [], []
        self._wrench = self._wheel = self._burn = None
        self._update_thrusts(None)

    def _next_seq(self, kind):
        seq = self._seq[kind]
        self._seq[kind] += 1
        return seq

    def _t_apply(self, kind, t_now, t_stamp):
        if not math.isfinite(t_stamp):
            raise ValueError(f'{kind} command stamp {t_stamp!r} is not finite')
        if t_stamp < t_now:
            lateness = t_now - t_stamp
            self._emit(Event(t_now, 'WARN', events.LATE_COMMAND,
                             f'{kind} command {self._seq[kind]} stamped {t_stamp:.3f} s arrived {lateness:.3f} s '
                             f'late; applied from {t_now:.3f} s',
                             dict(command=kind, seq=self._seq[kind], t_stamp=float(t_stamp), t_applied=t_now,
                                  lateness_s=lateness)))
            return t_now
        return float(t_stamp)

    # -- one step ---------------------------------------------------------------------------------
    def advance(self, t, t1):
        """Integrate from t to t1 [s] (one plant step), applying every command and burn on time; the step's
        means are then ``totals``."""
        self._acc = dict(impulse_hill=[0.0] * 3, angular_impulse_hill=[0.0] * 3, dv_hill=[0.0] * 3,
                         force_body=[0.0] * 3, torque_body=[0.0] * 3, thruster=[0.0] * self.layout.count,
                         wheel=[0.0] * self._nw, firing=False)
        while t < t1:
            self._apply_due(t, t1)
            t_end = min(t1, self._next_break(t))
            if t_end > t:
                self._segment(t, t_end, t1)
            t = t_end
            if self._burn is not None and t >= self._burn.end_s:
                self._end_burn(t, t1)
        self._sync_translation(t1)
        x, y, z, w = self._att[:4]
        norm = math.sqrt(x * x + y * y + z * z + w * w)
        self._att[:4] = [x / norm, y / norm, z / norm, w / norm]
        acc, k = self._acc, 1.0 / self.step_s
        self._totals = StepTotals(np.array(acc['impulse_hill']) * k, np.array(acc['force_body']) * k,
                                  np.array(acc['torque_body']) * k, np.array(acc['angular_impulse_hill']) * k,
                                  np.array(acc['thruster']) * k, np.array(acc['wheel']) * k, acc['firing'],
                                  np.array(acc['dv_hill']))
        return self._totals

    def advance_idle(self):
        """A step in which nothing fired and no wheel torque acted (the chaser attached to the target)."""
        self._totals = self._zero_totals()

    def _zero_totals(self):
        z3 = np.zeros(3)
        return StepTotals(z3, z3.copy(), z3.copy(), z3.copy(), np.zeros(self.layout.count), np.zeros(self._nw),
                          False, z3.copy())

    def _apply_due(self, t, t_event):
        changed = False
        while self._wrench_queue and self._wrench_queue[0].t_apply <= t:
            self._wrench = self._wrench_queue.pop(0)
            changed = True
        while self._wheel_queue and self._wheel_queue[0].t_apply <= t:
            self._wheel = self._wheel_queue.pop(0)
        if self._burn is None and self._requests and max(self._requests[0].request_s, self._last_burn_end) <= t:
            self._start_burn(t, t_event)
            changed = True
        if changed:
            self._update_thrusts(t_event)

    def _next_break(self, t):
        candidates = [math.inf]
        if self._wrench_queue:
            candidates.append(self._wrench_queue[0].t_apply)
        if self._wheel_queue:
            candidates.append(self._wheel_queue[0].t_apply)
        if self._burn is not None:
            candidates.append(self._burn.end_s)
        elif self._requests:
            candidates.append(max(self._requests[0].request_s, self._last_burn_end))
        for i, u in enumerate(self._wheel_torques()):
            if u != 0.0:  # h(t) = h + u (t - t0) exactly: the instant it reaches its limit
                t_limit = t + (math.copysign(self._h_max[i], u) - self._att[7 + i]) / u
                if t_limit <= t:  # there to round-off: on the limit from now
                    self._att[7 + i] = math.copysign(self._h_max[i], u)
                else:
                    candidates.append(t_limit)
        return min(candidates)

    def _report_wheel_limit(self, i, t, t_event):
        """Record (once per wheel command and wheel) that wheel i's momentum limit stops its commanded torque."""
        key = (events.WHEEL_MOMENTUM_LIMITED, self._wheel.seq, i)
        if key in self._reported:
            return
        self._reported.add(key)
        limit = math.copysign(self._h_max[i], self._wheel.torque_n_m[i])
        self._emit(Event(t_event, 'WARN', events.WHEEL_MOMENTUM_LIMITED,
                         f'wheel {i} at its momentum limit {limit:.4g} N m s at t = {t:.3f} s stops wheel command '
                         f'{self._wheel.seq}', dict(seq=self._wheel.seq, wheel=i, t=t, momentum_n_m_s=limit)))

    def _wheel_torques(self):
        """The motor torques acting now: the held command as the wheels' health gives it, none on a wheel at its
        momentum limit pushing out."""
        if self._wheel is None:
            return (0.0,) * self._nw
        h = self._att[7:]
        given = self.health.wheel_torques(self._wheel.torque_n_m, self._u_max)
        return tuple(0.0 if (u > 0.0 and h[i] >= self._h_max[i]) or (u < 0.0 and h[i] <= -self._h_max[i]) else u
                     for i, u in enumerate(given))

    def _update_thrusts(self, t_event):
        """The nominal thrusts of the burn and the held wrench together, each thruster at most its maximum
        (the burn's share first)."""
        n = self.layout.count
        burn = self._burn.thrusts_n if self._burn is not None else (0.0,) * n
        wrench = self._wrench.thrusts_n if self._wrench is not None else (0.0,) * n
        total = [min(b + w, f_max) for b, w, f_max in zip(burn, wrench, self._max_thrust, strict=True)]
        self._burn_share = burn
        self._wrench_share = tuple(f - b for f, b in zip(total, burn, strict=True))
        self._thrusts = tuple(total)
        self._actual = self.health.thrusts(self._thrusts)
        if self._burn is not None and self._wrench is not None and t_event is not None:
            clipped = [i for i in range(n) if burn[i] + wrench[i] > self._max_thrust[i]]
            key = (events.WRENCH_LIMITED_BY_BURN, self._wrench.seq, self._burn.seq)
            if clipped and key not in self._reported:
                self._reported.add(key)
                self._emit(Event(t_event, 'WARN', events.WRENCH_LIMITED_BY_BURN,
                                 f'wrench command {self._wrench.seq} limited on thrusters {clipped} during burn '
                                 f'{self._burn.seq}', dict(seq=self._wrench.seq, burn_seq=self._burn.seq,
                                                           thrusters=clipped)))

    def _start_burn(self, t, t_event):
        request = self._requests.pop(0)
        dv = np.array(request.dv_cmd_hill)
        dv_mps = float(np.linalg.norm(dv))
        direction_body = quat_rotate(quat_conjugate(self.q_hill_from_body(t)), dv / dv_mps)
        # pushed with the point-mass chaser's thrust, the burn the navigation filter models, on the thrusters allowed
        idx, layout = (np.arange(self.layout.count), self.layout) if self._allowed is None else self._allowed
        try:
            plan = plan_burn(layout, direction_body, dv_mps, self.mass_kg,
                             None if request.full_thrust else self.thrusters.max_thrust_n)
        except ValueError as err:  # thrusters closed (a fault's isolation) leave no pure force along it
            self._emit(Event(t_event, 'ERROR', events.MANEUVER_REJECTED, f'burn {request.seq} not flown: {err}',
                             dict(seq=request.seq, t_cmd=request.t_cmd_s, dv_hill=request.dv_cmd_hill)))
            return
        held = fire(layout, plan.allocation.thrusts_n, plan.duration_s)  # the minimum impulse bit
        thrusts = np.zeros(self.layout.count)
        thrusts[idx] = held.thrusts_n
        burn = ThrusterBurn(request.seq, request.t_cmd_s, t, t + plan.duration_s, request.dv_cmd_hill,
                            tuple(direction_body.tolist()), tuple(thrusts.tolist()), plan.allocation.force_n,
                            self.mass_kg, plan.fuel_kg, t > request.t_cmd_s)
        self._burn = burn
        self._burn_dv_hill = [0.0, 0.0, 0.0]
        # The delta-v it will deliver with the thrusters' errors if the attitude holds: F_actual / mdot ln(m0 / m1).
        force_actual = np.array(self._b_actual_columns).T[:3] @ np.array(burn.thrusts_n)
        flow = float(np.dot(self._factors, burn.thrusts_n)) / self._ve
        dv_body = force_actual / flow * math.log(self.mass_kg / (self.mass_kg - flow * plan.duration_s)) \
            if flow > 0.0 else np.zeros(3)
        dv_expected_hill = quat_rotate(self.q_hill_from_body(t), dv_body)
        self._emit(Event(t_event, 'OK', events.BURN_STARTED, f'burn {burn.seq} started at t = {t:.3f} s',
                         dict(seq=burn.seq, t_cmd=burn.t_cmd_s, t_start=burn.start_s, t_end=burn.end_s,
                              dv_cmd_hill=burn.dv_cmd_hill, dv_hill=dv_expected_hill,
                              direction_body=burn.direction_body,
                              force_n=burn.force_n, thrusts_n=burn.thrusts_n, mass_kg=burn.mass_start_kg,
                              below_minimum_impulse=idx[np.flatnonzero(held.below_minimum_impulse)],
                              minimum_impulse_allocated=plan.minimum_impulse_allocated)))
        if burn.late:
            lateness = burn.start_s - burn.t_cmd_s
            self._emit(Event(t_event, 'WARN', events.LATE_MANEUVER,
                             f'burn {burn.seq} stamped {burn.t_cmd_s:.3f} s started {lateness:.3f} s late',
                             dict(seq=burn.seq, t_cmd=burn.t_cmd_s, t_start=burn.start_s, lateness_s=lateness)))

    def _end_burn(self, t, t_event):
        burn, self._burn = self._burn, None
        self._last_burn_end = t
        self._update_thrusts(t_event)
        self._emit(Event(t_event, 'OK', events.BURN_ENDED, f'burn {burn.seq} ended at t = {t:.3f} s',
                         dict(seq=burn.seq, t_end=t, dv_cmd_hill=burn.dv_cmd_hill,
                              dv_delivered_hill=np.array(self._burn_dv_hill), fuel_kg=burn.fuel_kg,
                              mass_kg=self.mass_kg)))

    def _coast_rhs(self, t, y):
        return (y[3], y[4], y[5], *self._accel(y[:3], y[3:], _ZERO3))

    def _sync_translation(self, t):
        """The translation brought to t by coasting (one RK4 step, as the point-mass chaser's)."""
        if t > self._t_trans:
            self._y = rk4_step_floats(self._coast_rhs, self._t_trans, self._y, t - self._t_trans)
            self._t_trans = t

    def _segment(self, t, t_end, t_event):
        """Integrate [t, t_end] with the inputs held."""
        dt = t_end - t
        acc = self._acc
        u = self._wheel_torques()
        if self._wheel is not None:
            given = self.health.wheel_torques(self._wheel.torque_n_m, self._u_max)
            for i, (u_cmd, u_now) in enumerate(zip(given, u, strict=True)):
                if u_cmd != u_now:
                    self._report_wheel_limit(i, t, t_event)
        att = self._att
        wx, wy, wz = w = att[4:7]
        (i00, i01, i02), (i10, i11, i12), (i20, i21, i22) = self._inertia
        hx, hy, hz = i00 * wx + i01 * wy + i02 * wz, i10 * wx + i11 * wy + i12 * wz, i20 * wx + i21 * wy + i22 * wz
        for (ax, ay, az), h in zip(self._axes, att[7:], strict=True):
            hx += ax * h
            hy += ay * h
            hz += az * h
        substeps = substep_count(w, (hx, hy, hz), self._inertia_min, dt, MAX_SUBSTEP_ANGLE_RAD)
        h_sub = dt / substeps
        thrusts = self._actual
        if any(thrusts):
            self._sync_translation(t)
            self._check_restriction(t, t_event)
            force_b, torque_b = [0.0] * 3, [0.0] * 3
            flow = 0.0
            for f, column, factor in zip(thrusts, self._b_actual_columns, self._factors, strict=True):
                if f:
                    for k in range(3):
                        force_b[k] += column[k] * f
                        torque_b[k] += column[3 + k] * f
                    flow += factor * f
            mass_flow = flow / self._ve
            m0 = self.mass_kg
            rhs = self._thrusting_rhs(t, m0, mass_flow, force_b, torque_b, u)
            y = self._y + att + [0.0] * 9
            tau = t
            for _ in range(substeps):
                y = rk4_step_floats(rhs, tau, y, h_sub)
                tau += h_sub
            nw = self._nw
            self._y = y[:6]
            self._t_trans = t_end
            self._att = y[6:13 + nw]
            m1 = m0 - mass_flow * dt
            force_mag = math.sqrt(sum(c * c for c in force_b))
            self.dv_total_mps += force_mag / mass_flow * math.log(m0 / m1)  # integral of |F| / m dt
            self.mass_kg = m1
            for k in range(3):
                acc['impulse_hill'][k] += y[13 + nw + k]
                acc['dv_hill'][k] += y[19 + nw + k]
                acc['angular_impulse_hill'][k] += y[16 + nw + k]
                if self._burn is not None:
                    self._burn_dv_hill[k] += y[19 + nw + k]
                acc['force_body'][k] += force_b[k] * dt
                acc['torque_body'][k] += torque_b[k] * dt
            for i, (f, factor) in enumerate(zip(thrusts, self._factors, strict=True)):
                acc['thruster'][i] += factor * f * dt
            acc['firing'] = True
            self._check_restriction(t_end, t_event)
        else:
            inertia, inertia_inv, axes = self._inertia, self._inertia_inv, self._axes

            def rhs(_tau, y):
                return gyrostat_rates_floats(y[:4], y[4:7], y[7:], inertia, inertia_inv, axes, _ZERO3, u)

            y = att
            tau = t
            for _ in range(substeps):
                y = rk4_step_floats(rhs, tau, y, h_sub)
                tau += h_sub
            self._att = y
        for i, ui in enumerate(u):
            acc['wheel'][i] += ui * dt
        self._snap_wheel_limits(t, t_end, att, u, t_event)

    def _snap_wheel_limits(self, t, t_end, att0, u, t_event):
        """A wheel whose limit instant ends the segment sits exactly on its limit (no round-off past it)."""
        for i, ui in enumerate(u):
            if ui == 0.0:
                continue
            limit = math.copysign(self._h_max[i], ui)
            if t + (limit - att0[7 + i]) / ui <= t_end:
                self._att[7 + i] = limit
                self._report_wheel_limit(i, t_end, t_event)

    def _thrusting_rhs(self, t0, m0, mass_flow, force_b, torque_b, u):
        """d/dt of [r, v, q_eci_from_body, omega, h, impulse_hill, angular_impulse_hill, delta-v_hill] with the
        thrust held."""
        n = self._n
        accel = self._accel
        inertia, inertia_inv, axes = self._inertia, self._inertia_inv, self._axes
        fx, fy, fz = force_b
        mx, my, mz = torque_b
        h_end = 13 + self._nw

        def rotate(q, vx, vy, vz):  # quat_rotate on floats: v + w t + u x t, t = 2 u x v
            x, y, z, w = q
            tx = 2.0 * (y * vz - z * vy)
            ty = 2.0 * (z * vx - x * vz)
            tz = 2.0 * (x * vy - y * vx)
            return vx + w * tx + y * tz - z * ty, vy + w * ty + z * tx - x * tz, vz + w * tz + x * ty - y * tx

        def rhs(tau, y):
            q = y[6:10]
            s, c = math.sin(n * tau), math.cos(n * tau)
            ex, ey, ez = rotate(q, fx, fy, fz)  # force in ECI
            f_hill = (-s * ex + c * ey, -ez, -c * ex - s * ey)  # orbital.eci_vector_in_hill
            ex, ey, ez = rotate(q, mx, my, mz)
            m_hill = (-s * ex + c * ey, -ez, -c * ex - s * ey)
            k = 1.0 / (m0 - mass_flow * (tau - t0))  # 1 / m(t), mass falling linearly
            thrust_accel = (k * f_hill[0], k * f_hill[1], k * f_hill[2])
            a = accel(y[:3], y[3:6], thrust_accel)  # seed 000 eq 1-2
            rates = gyrostat_rates_floats(q, y[10:13], y[13:h_end], inertia, inertia_inv, axes, torque_b, u)
            return [y[3], y[4], y[5], *a, *rates, *f_hill, *m_hill, *thrust_accel]

        return rhs

    def _check_restriction(self, t, t_event):
        """Record thrust inside the thruster-restriction sphere: once per burn, and once per run of consecutive
        wrench commands that fire there."""
        x, y, z = self._y[:3]
        range_m = math.sqrt(x * x + y * y + z * z)
        if not range_m < self._radius_m:
            return
        sources = []
        if self._burn is not None and any(self._burn_share):
            sources.append(('burn', self._burn.seq))
        if self._wrench is not None and any(self._wrench_share):
            sources.append(('wrench', self._wrench.seq))
        for kind, seq in sources:
            key = (events.THRUST_INSIDE_RESTRICTION_SPHERE, kind, seq)
            if key in self._reported:
                continue
            self._reported.add(key)
            # Continuous thrust commands a wrench every control period: one event per run of consecutive
            # commands that fire inside the sphere, not one per command (thousands in a docking).
            if kind == 'wrench' and (events.THRUST_INSIDE_RESTRICTION_SPHERE, kind, seq - 1) in self._reported:
                continue
            self._emit(Event(t_event, 'ERROR', events.THRUST_INSIDE_RESTRICTION_SPHERE,
                             f'{kind} {seq} thrusts at {range_m:.3f} m, inside the {self._radius_m:.3f} m '
                             f'restriction sphere' + (' (its successors that fire there too are not reported '
                                                      'again)' if kind == 'wrench' else ''),
                             dict(source=kind, seq=seq, t=t, range_m=range_m,
                                  restriction_sphere_radius_m=self._radius_m)))
