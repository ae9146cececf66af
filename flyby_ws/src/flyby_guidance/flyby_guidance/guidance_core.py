"""What the guidance node does, without ROS: which plan it flies, when it steps, when it re-aims.

A new plan (the fly-by initial point X_Fi at t_i, the fly-by target point X_Ft at t_f, and the path
whose stamp is the plan time) starts ``FlybyGuidance`` (flyby_guidance.guidance) with its first burn
``planner.maneuver_lead_s`` after the plan time, as the planner assumed (t_Ti). Each chaser estimate
steps it, in order; the maneuvers it returns are commanded ahead of their start. Before each
adjusting burn the grasp is re-solved from the target estimate of the deciding chaser estimate's
stamp and the burn aims at it (seed 000 §4.6): a chaser estimate that re-aims waits for that target
estimate, so the aim is the same at any pace of the run. In the phases CAPTURE, ESCAPE, COMPLETE
and ABORTED nothing is commanded.

With the six-degree-of-freedom chaser (``chaser.model: rigid_body``) every chaser estimate (given at the
IMU's stamps, with the attitude) also gives an ``AttitudeCommandStamped``: the wheel motor torques
(guidance/wheels) and the thrusters' body torque (guidance/wrench) of ``attitude_guidance.AttitudeGuidance``
pointing body +x at the target's centre of mass, stamped one control period (the IMU's sample period) after
the estimate and held for one period (DESIGN §10: the simulator holds time at that stamp until the command
is in). The wheels' momentum is the guidance's own account of the torques it commanded (what the wheels
received, unless a wheel met its momentum limit, which the plant reports). No thruster torque is asked
within ``RESTRICTION_SPHERE_MARGIN_M`` of the restriction sphere (by the estimate); nothing is commanded from
CAPTURE on.

An optimization-based approach (planner/trajectory, seed 003 section 4) is flown by ``tracking``: every chaser
estimate's command also carries the force [N, chaser_body] of the tracking law (feed-forward plus feedback, the
plume rule, the acceleration bound) on guidance/wrench, with the same stamp and hold as the attitude command (the
mass counted down by the fuel of the forces commanded). When the estimate leaves the trajectory by more than
planner.optimal.replan_error_m guidance asks for a re-plan (``replan_requested``, once per trajectory) and flies
the old trajectory until the new one starts.

A synchronized approach (seed 001 section 2, ``sync_control``): stage 1 is its planner/trajectory, tracked as above
(no plume rule, the bound and gain of planner.sync); from the trajectory's end (the station's arrival) every
command is ``SyncGuidance``'s: the body-frame hold, the docking and their force, and the attitude synchronized with
the target's (the attitude law with ``SYNC_ATTITUDE``'s gains); its stage events (``station_reached``,
``attitude_synchronized``, ``docking_started``) move the supervisor's phases. After ESCAPE or an abort it retreats
along the port's outward direction, then nothing is commanded. The command of the chaser estimate of t is
computed from the target estimate stamped last *before* t (predicted to the command's time): the estimator
publishes the target estimate of t after the chaser estimate of t, and a rule on stamps, not on which message
came first, gives the same command at any pace and in the headless loop.

After the capture with a post_capture section (issue 16, ``post_capture.PostCaptureControl``): nothing is commanded
while the arm's impedance damps the contact, nor after it lets go (``grasp_released``: the plant takes no command, the
chaser drifts off); from the simulator's ``grasp_damped`` (the arm locked) every chaser
estimate stamped at or after its stamp (from t = 0 in a run that starts attached, which skips the damping) gets the
damping law's command, then the excitation's, each applied one
control period later (the simulator holds time for them as before the capture). The estimates that come before
that event are kept until it does (the topics race), so the commands are the same at any pace. With a transport
(issue 17, ``transport_control.TransportControl``) the estimates stamped from the end of the estimation's window on
wait likewise for the estimator's ``mass_properties_estimated``, which starts TRANSPORT, and in TRANSPORT those on
the grid of the refined combined CoM (``post_capture.on_com_grid``) for its ``transport_com_estimate``.

The guidance node and the headless driver (flyby_mission.headless) both run ``GuidanceCore``;
every input method returns the outputs to publish, in order: ``guidance.Maneuver`` (guidance/maneuver),
``AttitudeCommandStamped`` (guidance/wheels and guidance/wrench) and ``wire.Event`` (mission/events).
"""

import collections
import dataclasses
import math

import numpy as np

from flyby_estimation.post_capture import on_com_grid
from flyby_estimation.target_motion import ErrorStateDynamics, covariance_from_published, prediction_from_estimate
from flyby_guidance.attitude_guidance import AttitudeGuidance, AttitudeGuidanceConfig
from flyby_guidance.guidance import FlybyGuidance, FlybyTarget, guidance_config_from_scenario
from flyby_guidance.post_capture import (
    DampingGains,
    PostCaptureCommand,
    PostCaptureConfig,
    PostCaptureControl,
    inertia_upper_bound,
)
from flyby_guidance.sync_control import SYNC_ATTITUDE, SyncGuidance, sync_config_from_scenario
from flyby_guidance.tracking import (
    ReferenceTrajectory,
    TrackingConfig,
    tracking_acceleration,
    tracking_config_from_scenario,
)
from flyby_guidance.transport_control import (
    TransportControl,
    transport_body,
    transport_guidance_config_from_scenario,
)
from flyby_msgs_py import contract as c
from flyby_msgs_py.stamped import StampedBuffer
from flyby_msgs_py.wire import STAMP_TOLERANCE_S, Event
from flyby_planner.grasp import REFINE_HORIZON_S, flyby_target_point, offset_of_flyby_target, refine_grasp
from flyby_planner.plan import check_passage, planner_config_from_scenario
from flyby_sim.dynamics.actuators import allocate_wrench, fire
from flyby_sim.dynamics.attitude import attitude_ahead
from flyby_sim.dynamics.orbital import cw_accel
from flyby_sim.dynamics.rigid_body import ReactionWheels
from flyby_sim.dynamics.rotation import quat_conjugate, quat_rotate

QUIET_PHASES = (c.PHASE_CAPTURE, c.PHASE_ESCAPE, c.PHASE_COMPLETE, c.PHASE_ABORTED)
# The attitude control stops at the grasp (the combined body's control is a later capability).
ATTITUDE_QUIET_PHASES = (c.PHASE_CAPTURE, c.PHASE_COMPLETE)
# The phases in which the chaser holds the target (post_capture: its estimates wait for the arm's lock).
_ATTACHED_PHASES = (c.PHASE_CAPTURE,) + c.POST_CAPTURE_PHASES
# Thruster torque only this far outside the restriction sphere (by the estimate) [m]: the estimate's error and
# one control period of motion stay well inside it.
RESTRICTION_SPHERE_MARGIN_M = 1.0
# The damping's couple is fired in pulses of this many minimum impulse bits (post_capture_config_from_scenario).
DAMPING_PULSE_BITS = 4.0
# A re-aimed arc is flown if the chaser envelope keeps off the target's predicted geometry less its
# uncertainty [m]: the planner's clearance_margin_m is a planning margin, this is the floor (a plan
# 0.137 m clear re-aimed 0.096 m clear is no reason to give up a capture).
_GATE_MARGIN_M = 0.0


def flyby_target_of_plan(t_plan, t_i, x_fi, v_fi, t_f, x_ft, v_ft, maneuver_lead_s):
    """The FlybyTarget of a published plan: the first burn t_Ti is maneuver_lead_s after the plan time,
    as the planner assumed when it chose the transfer (plan.plan_capture)."""
    return FlybyTarget(t_ti=t_plan + maneuver_lead_s, t_i=t_i, x_fi=np.asarray(x_fi, dtype=float),
                       v_fi=np.asarray(v_fi, dtype=float), t_f=t_f, x_ft=np.asarray(x_ft, dtype=float),
                       v_ft=np.asarray(v_ft, dtype=float))


@dataclasses.dataclass(frozen=True)
class AttitudeCommandStamped:
    """guidance/wheels and guidance/wrench: from t [s] for hold_s [s], the wheels' motor torques [N m], the
    thrusters' torque about the CoM in chaser_body axes [N m] and their force in chaser_body axes [N] (zero but
    while tracking an optimal approach: the fly-by translates by maneuvers)."""

    t: float
    hold_s: float
    wheel_torque_n_m: np.ndarray
    thruster_torque_body_n_m: np.ndarray
    force_body_n: tuple = (0.0, 0.0, 0.0)


def post_capture_config_from_scenario(scenario):
    """The PostCaptureConfig of a scenario with a post_capture section (the gains for the inertia bound it gives, or
    half the smallest principal moment of the target's inertia; the IMU's period)."""
    pc = scenario.post_capture
    d = pc.damping
    period_s = 1.0 / scenario.sensors.chaser_imu.rate_hz
    bound = d.inertia_lower_bound_kg_m2 or 0.5 * float(np.linalg.eigvalsh(scenario.target_inertia)[0])
    gains = DampingGains.for_inertia_bound(bound, period_s, d.wheel_share,
                                           max_thruster_torque_n_m=d.max_thruster_torque_n_m,
                                           dump_rate_per_s=d.dump_rate_per_s)
    m = pc.mass_estimation
    layout = scenario.thruster_layout
    # A pulse: DAMPING_PULSE_BITS minimum impulse bits at the thrusters' mean lever arm about the chaser's CoM (a
    # wheel momentum of 0.26 N m s asks 0.013 N m of the thrusters, below the bit: paper_flyby_transport's damping
    # stalled at 0.39 kg m^2/s with four more thrusters).
    pulse = DAMPING_PULSE_BITS * layout.min_impulse_bit_n_s * float(np.mean(np.linalg.norm(
        layout.positions_body_m, axis=1)))
    return PostCaptureConfig(gains, period_s, d.momentum_threshold_kg_m2_s, d.settle_s, m.excitation, m.start_delay_s,
                             m.window_s, damping=pc.start != 'attached', pulse_n_m_s=pulse)


def attitude_guidance_from_scenario(scenario):
    """(AttitudeGuidance, wheels' initial momenta [N m s]) of a rigid-body chaser scenario."""
    w = scenario.chaser.wheels
    wheels = ReactionWheels(w.axes, w.max_torque_n_m, w.max_momentum_n_m_s, w.spin_inertia_kg_m2)
    g = scenario.guidance
    config = AttitudeGuidanceConfig(control_period_s=1.0 / scenario.sensors.chaser_imu.rate_hz,
                                    dump_start_n_m_s=g.momentum_dump_start_n_m_s,
                                    dump_stop_n_m_s=g.momentum_dump_stop_n_m_s)
    h0 = np.zeros(wheels.count) if w.initial_momentum_n_m_s is None else np.array(w.initial_momentum_n_m_s, float)
    return AttitudeGuidance(config, scenario.chaser_inertia, wheels), h0


class GuidanceCore:
    """The guidance's rules (module doc)."""

    def __init__(self, scenario, name='flyby_guidance'):
        self.scenario = scenario
        self.name = name
        self.guidance = FlybyGuidance(guidance_config_from_scenario(scenario))
        # The estimator's torque noise: the gate propagates the estimate's covariance as the filter would.
        self.dynamics = ErrorStateDynamics(scenario.target_inertia, scenario.estimation.torque_psd_n2m2s)
        self.planner_config = planner_config_from_scenario(scenario)
        self.n = scenario.mean_motion_rad_s
        self.x_grasp_body = np.array(scenario.target.grasp_point_body_m)
        self.phase = None
        self.flyby_initial = self.flyby_target = None  # (t, x, v) as last published
        self.plan_stamp = None  # the plan time of the plan being flown
        # (q_hill_from_body, omega_body, published covariance blocks (attitude in hill, rate in body) or None)
        self.targets = StampedBuffer()
        self.waiting = collections.deque()  # (t, r_hill, v_hill) chaser estimates not yet stepped, in order
        self.attitude = None
        if scenario.chaser.model == 'rigid_body':
            self.attitude, self.h_wheels_n_m_s = attitude_guidance_from_scenario(scenario)
            self.wheel_commands = collections.deque()  # (t, wheel torques) commanded, not yet in h_wheels
            self.sphere_radius_m = scenario.planner.restriction_sphere_radius_m + RESTRICTION_SPHERE_MARGIN_M
            self.tracking = tracking_config_from_scenario(scenario)
            self.mass_kg = scenario.chaser.mass_kg  # less the fuel of the forces commanded
            self.layout = scenario.thruster_layout
            self.force_carried_hill = np.zeros(3)  # below the thrusters' minimum impulse bit so far [N]
            self.sync = SyncGuidance(sync_config_from_scenario(scenario))
            self.sync_attitude = AttitudeGuidance(dataclasses.replace(SYNC_ATTITUDE, control_period_s=(
                self.attitude.config.control_period_s)), scenario.chaser_inertia, self.attitude.wheels)
        self.post = None  # after the capture (module doc)
        if self.attitude is not None and scenario.post_capture is not None:
            self.post = PostCaptureControl(post_capture_config_from_scenario(scenario),
                                           float(self.attitude.wheels.max_torque_n_m.min()))
            self.t_locked = None  # the arm's lock (the simulator's grasp_damped) [s]
            # Between the two CoMs [m]: the chaser estimate's distance from the target's after a capture, the
            # attachment's when the run starts attached (locked from t = 0; its position estimate is not measured).
            self.post_distance_m = None
            if scenario.post_capture.start == 'attached':
                self.t_locked = 0.0
                self.post_distance_m = float(np.linalg.norm(scenario.post_capture.attachment.target_com_chaser_body_m))
            self.post_released = False  # the arm let go (grasp_released)
            self.transport = None  # TRANSPORT after the estimation (issue 17, transport_control)
            if scenario.post_capture.transport is not None:
                self.transport = TransportControl(transport_guidance_config_from_scenario(
                    scenario, self.attitude.config.control_period_s), self.n, self.post.config.gains,
                    float(self.attitude.wheels.max_torque_n_m.min()),
                    float(np.min(self.attitude.wheels.max_momentum_n_m_s)))
            # (t, r_hill, v_hill, q_hill_from_body, omega_body) not yet commanded
            self.post_waiting = collections.deque()
        self.reference = None  # the ReferenceTrajectory flown (an optimal approach)
        self.next_reference = None  # a re-planned one, flown from its start
        self.replan_asked = False
        self.tracking_error_max_m = 0.0  # over the approach, by the estimates
        self.tracking_ended = False

    # -- the plan -------------------------------------------------------------------------------
    def on_flyby_initial(self, t_i, x_fi, v_fi):
        self.flyby_initial = (t_i, x_fi, v_fi)
        return []

    def on_flyby_target(self, t_f, x_ft, v_ft):
        self.flyby_target = (t_f, x_ft, v_ft)
        return []

    def on_path(self, t_plan):
        """The planner publishes the path last: a new plan is complete."""
        if self.flyby_initial is None or self.flyby_target is None or t_plan == self.plan_stamp:
            return []
        self.plan_stamp = t_plan
        target = flyby_target_of_plan(t_plan, *self.flyby_initial, *self.flyby_target,
                                      self.scenario.planner.maneuver_lead_s)
        self.guidance.set_target(target)
        return [self._event(t_plan, 'OK', 'guidance_started',
                            f'flying the plan of t = {t_plan:.2f} s: transfer at {target.t_ti:.2f} s, injection '
                            f'at {target.t_i:.2f} s, fly-by target at {target.t_f:.2f} s', {'t_plan_s': t_plan})]

    def on_trajectory(self, t_s, r_hill, v_hill, a_hill):
        """planner/trajectory: a new optimal approach to fly (module doc)."""
        if self.attitude is None:
            return [self._event(float(t_s[0]), 'ERROR', 'trajectory_ignored',
                                'an optimal approach needs the rigid-body chaser (continuous thrust)', {})]
        ref = ReferenceTrajectory(t_s, r_hill, v_hill, a_hill)
        if self.reference is None:
            self.reference = ref
        else:
            self.next_reference = ref
        if self.phase in c.SYNC_PHASES:
            self.sync.arm(ref.t_end)
        return [self._event(ref.t_start, 'OK', 'guidance_started',
                            f'tracking the optimal approach from t = {ref.t_start:.2f} s to {ref.t_end:.2f} s',
                            {'t_start_s': ref.t_start, 't_end_s': ref.t_end})]

    def on_phase(self, phase):
        self.phase = phase
        if phase == c.PHASE_SYNC_APPROACH and self.attitude is not None:
            cfg = self.sync.config  # stage 1: the link tracked without the plume rule, planner.sync's bound and gain
            self.tracking = TrackingConfig(cfg.accel_max_mps2, 0.0, cfg.frequency_rad_s, math.inf, 0.0)
            self.sync.arm((self.next_reference or self.reference).t_end)
        return []

    def on_target_estimate(self, t, q_hill_from_body, omega_body, attitude_covariance_hill=None,
                           rate_covariance_body=None):
        """A target estimate (estimation/target/odom) with, if published, its attitude covariance about hill
        axes and rate covariance in body axes (3x3 each): with them the gate weighs the estimate's own
        uncertainty, without them the planner's model."""
        # The blocks are kept as published and converted only for a re-aim (a few of thousands of estimates).
        blocks = (None if attitude_covariance_hill is None or rate_covariance_body is None else
                  (attitude_covariance_hill, rate_covariance_body))
        self.targets.add(t, (np.asarray(q_hill_from_body, dtype=float), np.asarray(omega_body, dtype=float), blocks))
        return self._step_waiting()

    def on_event(self, event):
        """An event of mission/events (wire.Event): the arm's lock or release after the capture (module doc)."""
        if self.post is None:
            return []
        if event.name == 'grasp_damped' and self.t_locked is None:
            self.t_locked = event.t
            return self._post_commands()
        if event.name == 'grasp_released':
            self.post_released = True  # the plant takes no command after the arm let go: the chaser drifts off
            self.post_waiting.clear()
        if event.name == 'mass_properties_estimated' and self.transport is not None \
                and self.transport.t_start is None:
            self.transport.start(event.t, transport_body(event.values, self.mass_kg, self.scenario.chaser_inertia,
                                                         self.layout, self.transport.config.plume_cone_deg))
            return self._post_commands()
        if event.name == 'transport_com_estimate' and self.transport is not None \
                and self.transport.t_start is not None:
            self.transport.refine_com(event.t, event.values)
            return self._post_commands()
        return []

    def on_chaser_estimate(self, t, r_hill, v_hill, q_hill_from_body=None, omega_body=None):
        """A chaser estimate (estimation/chaser/odom), with the rigid-body chaser's attitude and body rate."""
        r_hill, v_hill = np.asarray(r_hill, dtype=float), np.asarray(v_hill, dtype=float)
        if self.post is not None and self.post_released:
            return []
        if self.post is not None and (self.t_locked is not None or self.phase in _ATTACHED_PHASES):
            self.post_waiting.append((t, r_hill, v_hill, np.asarray(q_hill_from_body, dtype=float),
                                      np.asarray(omega_body, dtype=float)))
            return self._post_commands()
        self.waiting.append((t, r_hill, v_hill))
        out = self._step_waiting()
        if self.attitude is not None and q_hill_from_body is not None and self.phase not in ATTITUDE_QUIET_PHASES:
            out += self._attitude_command(t, r_hill, v_hill, q_hill_from_body, omega_body)
        return out

    def _attitude_command(self, t, r_hill, v_hill, q_hill_from_body, omega_body):
        """The attitude command of the estimate at t, applied one control period later, with the tracking force of
        an optimal approach, and the tracking's events (module doc). While tracking, the pointing goal's feed-forward
        takes the commanded thrust (the line of sight turns with it)."""
        period_s = self.attitude.config.control_period_s
        self._account_wheels(t)
        if self.sync.stage is not None:
            out = self._sync_command(t, r_hill, v_hill, q_hill_from_body, omega_body)
            if out is not None:
                return out
        a_thrust_hill, events = self._tracking_acceleration(t, t + period_s, r_hill, v_hill)
        inside = float(np.linalg.norm(r_hill)) < self.sphere_radius_m
        cmd = self.attitude.command(t, np.asarray(q_hill_from_body, dtype=float), np.asarray(omega_body, dtype=float),
                                    self.h_wheels_n_m_s, r_hill, v_hill, self.n, inside,
                                    None if a_thrust_hill is None else cw_accel(r_hill, v_hill, self.n, a_thrust_hill))
        self.wheel_commands.append((t + period_s, cmd.wheel_torque_n_m))
        force_body = (0.0, 0.0, 0.0) if a_thrust_hill is None else self._tracking_force(
            a_thrust_hill, q_hill_from_body, cmd.thruster_torque_body_n_m)
        return [AttitudeCommandStamped(t + period_s, period_s, cmd.wheel_torque_n_m, cmd.thruster_torque_body_n_m,
                                       force_body)] + events

    def _account_wheels(self, t):
        """The wheels' momentum with every wheel command whose hold ended by t (module doc). After the capture a
        wheel stops at its momentum limit as the plant's does (the damping drives them there: h + u dt, clipped, is
        what the wheel holds at the hold's end)."""
        period_s = self.attitude.config.control_period_s
        while self.wheel_commands and self.wheel_commands[0][0] + period_s <= t + 1e-9:
            self.h_wheels_n_m_s = self.h_wheels_n_m_s + period_s * self.wheel_commands.popleft()[1]
            if self.post is not None and self.t_locked is not None:
                h_max = self.attitude.wheels.max_momentum_n_m_s
                self.h_wheels_n_m_s = np.clip(self.h_wheels_n_m_s, -h_max, h_max)

    def _waits_for_transport(self, t):
        """True for an estimate whose command depends on an estimate of the estimator still on its way: stamped at or
        after the mass-property estimate's end (the excitation's start plus its window) while TRANSPORT has not
        started, or in TRANSPORT on the grid of the refined combined CoM (``transport_com_estimate``) before it."""
        if self.transport is None or self.post.t_excitation is None:
            return False
        if self.transport.t_start is not None:  # the combined CoM refined on its grid (estimator's transport nav)
            return on_com_grid(t, self.transport.t_start) and (
                self.transport.t_com is None or self.transport.t_com < t - STAMP_TOLERANCE_S)
        return t >= self.post.t_excitation + self.post.config.window_s - STAMP_TOLERANCE_S

    def _post_commands(self):
        """The commands of the chaser estimates after the capture, from the arm's lock on (module doc)."""
        out = []
        while self.post is not None and self.t_locked is not None and self.post_waiting \
                and self.phase != c.PHASE_COMPLETE:
            t, r_hill, v_hill, q_hill_from_body, omega_body = self.post_waiting[0]
            if self._waits_for_transport(t):
                break  # the estimator's final estimate, stamped at this estimate's, is still on its way
            self.post_waiting.popleft()
            if t < self.t_locked - STAMP_TOLERANCE_S:
                continue  # the arm's impedance had it
            self._account_wheels(t)
            period_s = self.attitude.config.control_period_s
            wheels = self.attitude.wheels
            axes = wheels.axis_matrix
            h_settled = np.clip(self.h_wheels_n_m_s + period_s * sum((u for _, u in self.wheel_commands),
                                                                      np.zeros(wheels.count)),
                                -wheels.max_momentum_n_m_s, wheels.max_momentum_n_m_s)
            if self.transport is not None and self.transport.t_start is not None \
                    and t >= self.transport.t_start - STAMP_TOLERANCE_S:  # the excitation is over by then
                cmd = PostCaptureCommand(*self.transport.command(t, r_hill, v_hill, q_hill_from_body, omega_body,
                                                                 axes @ self.h_wheels_n_m_s))
            else:
                sc = self.scenario
                bound = inertia_upper_bound(sc.chaser_inertia, sc.target_inertia, sc.chaser.mass_kg,
                                            sc.target.mass_kg, float(np.linalg.norm(r_hill))
                                            if self.post_distance_m is None else self.post_distance_m)
                cmd = self.post.command(t, omega_body, axes @ self.h_wheels_n_m_s, axes @ h_settled, bound)
            wheel_torque = np.linalg.pinv(axes) @ cmd.wheel_torque_body_n_m
            self.wheel_commands.append((t + period_s, wheel_torque))
            out.append(AttitudeCommandStamped(t + period_s, period_s, wheel_torque, cmd.torque_body_n_m,
                                              tuple(cmd.force_body_n.tolist())))
            out += [self._event(t, *e) for e in cmd.events]
        return out

    def _sync_command(self, t, r_hill, v_hill, q_hill_from_body, omega_body):
        """The command of the synchronized approach's stages 2-4 or its retreat (module doc), or None where
        SyncGuidance has nothing to say (stage 1 before the arrival, the drift after a retreat)."""
        if self.phase in (c.PHASE_ESCAPE, c.PHASE_ABORTED):  # no capture: leave the final point
            self.sync.abort(t)
        target = self.targets.last_at_or_before(t - STAMP_TOLERANCE_S)  # module doc: the one before t
        if target is None:
            return None
        period_s = self.attitude.config.control_period_s
        cmd = self.sync.command(t, t + period_s, period_s, r_hill, v_hill, q_hill_from_body, omega_body,
                                (target[0], *target[1]))
        if cmd is None:
            return None
        events = [self._event(t, level, name, message, values) for level, name, message, values in cmd.events]
        if cmd.goal is None:  # the retreat: body +x back on the target's centre of mass
            att = self.attitude.command(t, np.asarray(q_hill_from_body, dtype=float),
                                        np.asarray(omega_body, dtype=float), self.h_wheels_n_m_s, r_hill, v_hill,
                                        self.n, True)
        else:
            att = self.sync_attitude.track(cmd.goal, np.asarray(q_hill_from_body, dtype=float),
                                           np.asarray(omega_body, dtype=float), self.h_wheels_n_m_s, False)
        self.wheel_commands.append((t + period_s, att.wheel_torque_n_m))
        force_body = (0.0, 0.0, 0.0) if cmd.a_hill is None else self._tracking_force(
            cmd.a_hill, attitude_ahead(q_hill_from_body, omega_body, 1.5 * period_s, self.n),
            att.thruster_torque_body_n_m)
        return [AttitudeCommandStamped(t + period_s, period_s, att.wheel_torque_n_m, att.thruster_torque_body_n_m,
                                       force_body)] + events

    def _tracking_acceleration(self, t, t_apply, r_hill, v_hill):
        """(thrust acceleration [m/s^2, hill] of the tracking law held from t_apply, or None where nothing is
        tracked; events) for the estimate of t (module doc)."""
        if self.next_reference is not None and t_apply >= self.next_reference.t_start:
            self.reference, self.next_reference, self.replan_asked = self.next_reference, None, False
        ref = self.reference
        if ref is None or self.phase in QUIET_PHASES or t_apply < ref.t_start or self.tracking_ended:
            return None, []
        if t_apply >= ref.t_end:
            self.tracking_ended = True
            return None, [self._event(t, 'OK', 'tracking_ended',
                                      f'end of the trajectory at t = {ref.t_end:.2f} s; largest tracking error '
                                      f'{self.tracking_error_max_m:.3f} m (estimate)',
                                      {'tracking_error_max_m': self.tracking_error_max_m})]
        events = []
        error_m = ref.error(t, r_hill)
        self.tracking_error_max_m = max(self.tracking_error_max_m, error_m)
        if error_m > self.tracking.replan_error_m and not self.replan_asked \
                and t < ref.t_end - self.tracking.replan_cutoff_s:
            self.replan_asked = True
            events.append(self._event(t, 'WARN', 'replan_requested',
                                      f'tracking error {error_m:.3f} m > {self.tracking.replan_error_m:g} m',
                                      {'tracking_error_m': error_m}))
        period_s = self.attitude.config.control_period_s
        return tracking_acceleration(ref, t_apply, period_s, t, r_hill, v_hill, self.tracking), events

    def _tracking_force(self, a_hill, q_hill_from_body, torque_body_n_m):
        """The force [N, chaser_body] for the thrust acceleration a_hill [m/s^2]. The thrusters fire it with
        torque_body_n_m as the plant allocates them (the nominal layout, least thrust); what a thruster below its
        minimum impulse bit leaves out is carried into the next command, so the mean force is the one commanded
        (otherwise the feedback's small corrections, about 0.1 N, are lost)."""
        force_body = quat_rotate(quat_conjugate(q_hill_from_body), self.mass_kg * a_hill + self.force_carried_hill)
        firing = fire(self.layout, allocate_wrench(self.layout, force_body, torque_body_n_m).thrusts_n,
                      self.attitude.config.control_period_s)
        self.force_carried_hill = quat_rotate(q_hill_from_body, force_body - firing.force_body_n)
        self.mass_kg -= firing.fuel_kg
        return tuple(force_body.tolist())

    # -- stepping -------------------------------------------------------------------------------
    def _step_waiting(self):
        """Step with the chaser estimates in order; one that re-aims waits for the target estimate of
        its own stamp."""
        g = self.guidance
        out = []
        while self.waiting:
            t, r_hill, v_hill = self.waiting[0]
            if g.next_burn_time is None or self.phase in QUIET_PHASES:
                self.waiting.clear()
                break
            if self.scenario.guidance.refine_target and g.wants_refined_target(t):
                target = self.targets.first_at_or_after(t)
                if target is None:
                    break
                out += self._refine(t, target)
            self.waiting.popleft()
            out += self._step(t, r_hill, v_hill)
        return out

    def _step(self, t, r_hill, v_hill):
        maneuvers, events = self.guidance.step(t, r_hill, v_hill)
        out = []
        for mv in maneuvers:
            out.append(mv)
            out.append(self._event(t, 'OK', 'maneuver_commanded',
                                   f'{mv.kind} burn of {np.linalg.norm(mv.dv_hill) * 1e3:.2f} mm/s at t = {mv.t:.2f} s',
                                   {'kind': mv.kind, 't_burn_s': mv.t, 'dv_hill_mps': [float(x) for x in mv.dv_hill],
                                    **mv.values}))
        return out + [e._replace(source=self.name) for e in events]

    def _refine(self, t, target):
        """Re-aim at the grasp re-solved from the target estimate (stamp, (q, omega)), seed 000 §4.6, if the
        passive arc through it keeps off the target by that estimate (plan.check_passage, the planner's
        step 4, with the floor _GATE_MARGIN_M);
        otherwise keep the aim if its arc still is, or stop thrusting and report the fault (the
        supervisor aborts and escapes): a re-aim never flies the chaser onto an unsafe arc."""
        t_est, (q_hb, omega_body, blocks) = target
        aim = self.guidance.target
        if aim.t_f <= t_est:
            return []
        covariance = None if blocks is None else covariance_from_published(q_hb, *blocks)
        cfg = self.planner_config
        prediction = prediction_from_estimate(self.dynamics, self.n, t_est, q_hb, omega_body,
                                              aim.t_f + max(REFINE_HORIZON_S, cfg.geometry_window_s), covariance)
        g = refine_grasp(prediction, self.x_grasp_body, aim.t_f, self.n, t_latest=aim.t_f + REFINE_HORIZON_S)
        if g is not None:
            offset_m = offset_of_flyby_target(aim.x_ft, self.x_grasp_body)
            x_ft, v_ft = flyby_target_point(g.x_g, g.v_g, offset_m)  # eq 20-21
            check = check_passage(prediction, x_ft, v_ft, g.t_grasp, t, cfg, _GATE_MARGIN_M)
            if check.safe:
                shift = float(np.linalg.norm(x_ft - aim.x_ft))
                self.guidance.retarget(g.t_grasp, x_ft, v_ft)
                at_grasp = prediction.state(g.t_grasp)
                return [self._event(t, 'OK', 'target_refined',
                                    f'grasp re-solved at t = {g.t_grasp:.3f} s, aim moved {shift * 1e3:.1f} mm',
                                    {'t_grasp_s': g.t_grasp, 'shift_m': shift, 'x_g_hill_m': g.x_g,
                                     'v_g_hill_mps': g.v_g, 'x_ft_hill_m': x_ft, 'v_ft_hill_mps': v_ft,
                                     'q_hill_from_body': at_grasp.q_hill_from_body,
                                     'omega_body_rad_s': at_grasp.omega_body, 'passage_gap_m': check.gap_m})]
            why = (f'the arc through the grasp re-solved at t = {g.t_grasp:.3f} s would come {check.gap_m:.3f} m '
                   f'from the {check.closest} at t = {check.t_min_gap:.1f} s (margin {check.margin_m:g} m)')
        else:
            why = 'no convex grasp near the planned one'
        kept = check_passage(prediction, aim.x_ft, aim.v_ft, aim.t_f, t, cfg, _GATE_MARGIN_M)
        if kept.safe:
            return [self._event(t, 'WARN', 'target_refined', f'{why}; keeping the aim, whose arc keeps '
                                                             f'{kept.gap_m:.3f} m', {'passage_gap_m': kept.gap_m})]
        self.guidance.stop(f'no safe arc at t = {t:.1f} s')
        return [self._event(t, 'ERROR', 'passage_unsafe',
                            f'{why}, and the arc flown now would come {kept.gap_m:.3f} m from the {kept.closest} at '
                            f't = {kept.t_min_gap:.1f} s: no thrust onto either, escape',
                            {'passage_gap_m': kept.gap_m, 'closest': kept.closest, 't_min_gap_s': kept.t_min_gap})]

    def _event(self, t, level, name, message, values):
        return Event(t, level, name, message, values, self.name)
