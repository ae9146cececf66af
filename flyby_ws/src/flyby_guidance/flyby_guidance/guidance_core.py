"""What the guidance node does, without ROS: the chaser estimates and the planner's and the mission's messages in,
the commands out, by guidance's modes (``flyby_guidance.modes``), each behind one interface
(``modes.interface.GuidanceMode``: ``command`` of a chaser estimate, or None where it is not the mode's).

The modes a scenario has are chosen once from its record (``flyby_guidance.params.GuidanceParams``: a sub-record per
mode, None for a mode it does not fly), and each chaser estimate goes, in this order, to:

1. after the capture (a post_capture section on the rigid-body chaser), the damping and excitation
   (``modes.damping``), or with a transport section those then TRANSPORT (``modes.transport``): the estimates from the
   arm's lock on (or in the attached phases, to wait for it) are theirs;
2. else the fly-by's adjusting burns (``modes.flyby``), which step on every estimate, and with the six-degree-of-freedom
   chaser (``chaser.model: rigid_body``; ``modes.chaser``) outside CAPTURE and COMPLETE the attitude command of the
   first of its modes that has one: the synchronized hold (``modes.synchronized``), else the pointing and the tracking
   of a planned trajectory (``modes.tracking``).

When the supervisor's core raises (its ``node_error``, flyby_msgs_py.core_guard) the mission has no judge: no phase
changes, no abort, no avoidance burn. Guidance then idles propulsion, as flight software answers a lost mission
manager (Astrobee's fault table: ``idlePropulsion``): from the event's arrival no burn and no thrust is commanded
(one ERROR ``propulsion_idled`` says so). The six-degree-of-freedom chaser's commands go on with the wheels alone
(the simulator holds time for them): before the grasp the pointing (``RigidBodyChaser.idle_command``), which keeps
the target in the sensors' view, holding the target the capture's modes' wheel commands. A burn commanded before
the event, up to ``guidance.command_lead_s`` ahead, is already with the thrusters and still flies. The independent
CAM monitor stays armed (docs/runtime.md).

Which mode commands an estimate follows the estimates' stamps and the modes' own state (a trajectory's start, the
arm's lock, TRANSPORT's start), not the order in which messages come: the commands are the same at any pace. The
guidance node and the headless driver (flyby_mission.headless) both run ``GuidanceCore``; every input method returns
the outputs to publish, in order: ``guidance.Maneuver`` (guidance/maneuver), ``AttitudeCommandStamped``
(guidance/wheels and guidance/wrench) and ``wire.Event`` (mission/events).
"""

import dataclasses

import numpy as np

from flyby_guidance.modes.chaser import PointMassChaser, RigidBodyChaser
from flyby_guidance.modes.damping import DampingMode, NotCaptured
from flyby_guidance.modes.flyby import FlybyAdjusting
from flyby_guidance.modes.interface import AttitudeCommandStamped, ChaserEstimate
from flyby_guidance.modes.transport import TransportMode
from flyby_guidance.params import GuidanceParams
from flyby_msgs_py import contract as c
from flyby_msgs_py import event_payloads, events, wiring
from flyby_msgs_py.core_guard import failed_node
from flyby_msgs_py.stamped import StampedBuffer
from flyby_msgs_py.wire import Event

# The attitude control stops at the grasp (after it the capture's modes command the combined body).
ATTITUDE_QUIET_PHASES = (c.PHASE_CAPTURE, c.PHASE_COMPLETE)
# The phases in which the chaser holds the target: with propulsion idle only the capture's modes' wheels command.
HOLDING_PHASES = (c.PHASE_CAPTURE,) + c.POST_CAPTURE_PHASES + (c.PHASE_COMPLETE,)


def without_thrust(outputs):
    """The attitude commands among outputs with no thruster firing (force and torque zero), nothing else: the capture's
    modes' commands once propulsion is idle (module doc)."""
    return [dataclasses.replace(out, thruster_torque_body_n_m=np.zeros(3), force_body_n=(0.0, 0.0, 0.0))
            for out in outputs if isinstance(out, AttitudeCommandStamped)]


def supervisor_lost(event):
    """Whether a mission/events Event is the supervisor's core's node_error (module doc)."""
    return failed_node(event.name, event.values) == wiring.SUPERVISOR


def chaser_of(params, source, targets):
    """The chaser's modes: a RigidBodyChaser with the rigid-body chaser's records, else a PointMassChaser."""
    if params.chaser is None:
        return PointMassChaser(source)
    return RigidBodyChaser(params.chaser, params.tracking, params.synchronized, source, targets)


def capture_of(params, source, chaser):
    """The mode after the capture: TransportMode with a transport record, DampingMode with a damping record (a
    post_capture section on the rigid-body chaser), else NotCaptured."""
    if params.damping is None:
        return NotCaptured(source)
    if params.transport is not None:
        return TransportMode(params.damping, params.transport, source, chaser)
    return DampingMode(params.damping, source, chaser)


class GuidanceCore:
    """The guidance's rules (module doc)."""

    def __init__(self, params: GuidanceParams, name='flyby_guidance'):
        """params: the GuidanceParams of the scenario (``GuidanceParams.from_scenario``)."""
        self.params = params
        self.name = name
        self.phase = None
        # (q_hill_from_body, omega_body, published covariance blocks (attitude in hill, rate in body) or None)
        self.targets = StampedBuffer()
        self.flyby = FlybyAdjusting(params.flyby, name, self.targets)
        self.chaser = chaser_of(params, name, self.targets)
        self.capture = capture_of(params, name, self.chaser)
        self.t_idle_s = None  # the stamp of the supervisor's node_error once heard: propulsion idle (module doc)
        self.t_wait_end_s = None  # the stamp the supervisor's last HOLD or RETREAT ended: a plan older is given up

    # -- the plan -------------------------------------------------------------------------------
    def on_flyby_initial(self, t_i, x_fi, v_fi):
        return self.flyby.on_flyby_initial(t_i, x_fi, v_fi)

    def on_flyby_target(self, t_f, x_ft, v_ft):
        return self.flyby.on_flyby_target(t_f, x_ft, v_ft)

    def on_path(self, t_plan):
        """The planner publishes the path last: a new plan is complete. None is taken in HOLD or RETREAT, nor one
        stamped before the last of them ended (``_on_wait``; a respawned guidance is fed the latched plan of an
        approach given up before the events that tell it so)."""
        if self.phase in c.WAITING_PHASES or (self.t_wait_end_s is not None and t_plan < self.t_wait_end_s):
            return []
        return self.flyby.on_path(t_plan)

    def on_trajectory(self, t_s, r_hill, v_hill, a_hill):
        """planner/trajectory: a new optimal approach to fly (``modes.tracking``; none taken in HOLD or RETREAT)."""
        if self.phase in c.WAITING_PHASES:
            return []
        return self.chaser.on_trajectory(t_s, r_hill, v_hill, a_hill, self.phase)

    def on_phase(self, phase):
        """The supervisor's phase; HOLD and RETREAT drop the plan of the standby or approach they interrupted (a plan
        the planner made before it heard them is never flown: the next is made after the fault's recovery)."""
        self.phase = phase
        if phase in c.WAITING_PHASES:
            self._drop_plan()
        self.chaser.on_phase(phase)
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
        if self.t_idle_s is not None:  # the chaser estimates waiting for it would be stepped into burns
            return []
        return self.flyby.step_waiting(self.phase)

    def on_event(self, event):
        """An event of mission/events (wire.Event): the supervisor's node_error (propulsion idled, module doc), a wheel
        fault's wheels_reallocated (``modes.chaser``), the arm's lock or release after the capture, the estimator's
        final mass-property estimate and refined combined CoM (``modes.damping``, ``modes.transport``)."""
        if supervisor_lost(event):
            return self._idle_propulsion(event)
        if event.name == events.PHASE_CHANGED:
            self._on_wait(event)
        return self.chaser.on_event(event, self.phase) + self.capture.on_event(event, self.phase)

    def _drop_plan(self):
        """The fly-by's and the tracked approach's plans dropped (HOLD, RETREAT)."""
        self.flyby.drop_plan()
        self.chaser.drop_plan()

    def _on_wait(self, event):
        """A phase_changed into HOLD or RETREAT drops the plan (as mission/phase does: the two topics come in either
        order); one out of them stamps the end of the wait."""
        change = event_payloads.decode(event)
        if change.to_phase in c.WAITING_PHASES:
            self._drop_plan()
        elif change.from_phase in c.WAITING_PHASES:
            self.t_wait_end_s = event.t

    def _idle_propulsion(self, error):
        """Propulsion idle from now on (module doc), once: its ERROR propulsion_idled event, stamped at the error."""
        if self.t_idle_s is not None:
            return []
        self.t_idle_s = error.t
        attitude = '; the wheels alone hold the attitude' if isinstance(self.chaser, RigidBodyChaser) else ''
        return [Event(error.t, 'ERROR', events.PROPULSION_IDLED,
                      f'the supervisor\'s core raised ({error.message}): no burn or thrust commanded from now on'
                      f'{attitude}', event_payloads.encode(event_payloads.PropulsionIdled(
                          error.t, event_payloads.decode(error).exception)), self.name)]

    def on_chaser_estimate(self, t, r_hill, v_hill, q_hill_from_body=None, omega_body=None):
        """A chaser estimate (estimation/chaser/odom), with the rigid-body chaser's attitude and body rate."""
        estimate = ChaserEstimate(t, np.asarray(r_hill, dtype=float), np.asarray(v_hill, dtype=float),
                                  q_hill_from_body, omega_body)
        if self.t_idle_s is not None and self.phase in HOLDING_PHASES:
            return without_thrust(self.capture.command(estimate, self.phase) or [])
        if self.t_idle_s is not None:
            return self.chaser.idle_command(estimate)
        out = self.capture.command(estimate, self.phase)
        if out is not None:
            return out
        out = self.flyby.command(estimate, self.phase)
        if q_hill_from_body is not None and self.phase not in ATTITUDE_QUIET_PHASES:
            out += self.chaser.command(estimate, self.phase)
        return out
