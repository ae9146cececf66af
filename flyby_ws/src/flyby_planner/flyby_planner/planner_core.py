"""What the planner node does, without ROS: when to plan, from which estimates, and what it publishes.

The planner plans when the supervisor turns the mission to PLANNING (its stamped ``phase_changed``
event) or on a replan request, at the first target estimate stamped at or after the request, once
the chaser estimates up to that stamp are in: the plan time is that estimate's stamp, the same at
any pace of the run. The target motion is predicted from that estimate (attitude, body rate, the
scenario's inertia), the chaser state is the last chaser estimate up to the plan time carried to it
along CW (seed 000 eq 22). The planning itself is ``flyby_planner.flyby`` (seed 000 §4.3-4.5, 4.7).

When guidance re-aims at a re-solved grasp (its ``target_refined`` event), the grasp and the fly-by
target point the mission now aims at are published again (``AimUpdate``), so the bag holds what was
flown, not only the first plan; so are, when a synchronized approach starts docking (``docking_started``), the
port and the final point at its grasp time (the simulator holds the capture decision at that stamp).

``planner.method`` (DESIGN §10) chooses the method: ``flyby`` plans the fly-by only; ``optimal`` the
optimization-based approach only (seed 003 section 4, ``flyby_planner.optimal.approach``; a rigid-body chaser);
``auto`` the fly-by, and the optimization-based approach when the fly-by finds no safe plan and the chaser is a
rigid body. The choice and its reason are a ``method_chosen`` event; nothing safe from any method tried is a
``plan_refused`` with every method's reason. An optimal plan is published as ``TrajectoryPublished``
(planner/grasp, planner/flyby_target = X_Ft, V_Ft at the grasp, planner/trajectory, planner/path). Guidance's
``replan_requested`` event (the tracking error grew beyond its bound) plans the approach again from the
estimates of its stamp to the same grasp time: the chaser's state at the new start is the estimate moved as the
trajectory flown moves over the lead (guidance flies it until the new one starts). The planner re-aims the same
way: every ``planner.optimal.reaim_interval_s`` it predicts the end point X_Ft at the grasp time from the newest
target estimate, and when that has moved by more than ``reaim_error_m`` from the plan's (a tumbler's motion
predicted 100 s ahead from one estimate misses by centimetres; outside the last ``replan_cutoff_s``) it plans again
to the new end point. A re-aim that finds no safe plan is a WARN ``reaim_refused``: the plan flown stays.
Each method is behind one protocol (flyby_planner.methods), the choice among them in one place (``choose``).

Several chasers (a ``chasers:`` scenario, seed 003 Fig 12) plan in the file's order: a chaser's planner takes
the earlier chasers' (its leaders') plan decisions (``plan_selected``, ``plan_refused`` on
``/<leader>/mission/events``) and trajectories (``/<leader>/planner/trajectory``) and plans at the first target
estimate stamped at or after both its request and each leader's decision (the leader's decision latest at or
before the request, else its first after it): the plan time is a stamp, the same at any pace, and the simulator
cannot run past it by more than its flow-control window while the leader plans. An optimization-based approach
then keeps its envelope off the leaders' planned motion (flyby_planner.optimal.mutual: keep-out planes and mutual
safety in SCP, the dense separation checked before it is flown, at least planner.clearance_margin_m); the
predicted least separation goes on ``plan_selected`` (``separation_m``, ``t_separation_s``, ``separation_from``).
A fly-by plan does not look at the leaders.

The planner node and the headless driver (flyby_mission.headless) both run ``PlannerCore`` with the scenario's
``PlannerParams`` (flyby_planner.params); every input method returns the outputs to publish, in order.
"""


import numpy as np

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_estimation.target_motion import covariance_from_published, prediction_from_estimate
from flyby_msgs_py import contract as c
from flyby_msgs_py import event_payloads, events
from flyby_msgs_py.stamped import StampedBuffer
from flyby_msgs_py.wire import Event
from flyby_planner.methods import FlybyMethod, OptimalMethod, SyncMethod, choose
from flyby_planner.optimal.mutual import MovingObstacle
from flyby_planner.optimal.problem import TargetMotion
from flyby_planner.optimal.scp import ScpSettings
from flyby_planner.params import PlannerParams
from flyby_planner.plan_outputs import AimUpdate, GraspState, PlanRefused
from flyby_sim.dynamics.orbital import cw_coast


def _array(vector):
    """A payload's vector (flyby_msgs_py.event_payloads) as a float array."""
    return np.array(vector, dtype=float)


# The reason of the request the supervisor's PLANNING makes (``on_event``).
PLANNING_REQUEST = 'phase PLANNING'


class PlannerCore:
    """The planner's rules (module doc)."""

    def __init__(self, params: PlannerParams, name='flyby_planner'):
        self.params = params
        self.name = name
        self.dynamics = ErrorStateDynamics(params.flyby.inertia_kg_m2)
        self.request = None  # (t_request, why) until the plan is made
        self.targets = StampedBuffer()  # (q_hill_from_body, omega_body, covariance blocks or None) by stamp
        self.chasers = StampedBuffer()  # (r_hill, v_hill) by stamp
        self.plans = 0
        self.leaders = tuple(params.leader_envelope_radius_m)  # chasers that plan before this
        self.leader_decisions = {name: [] for name in self.leaders}  # [(t_plan, t_start or None)] as they came
        self.leader_trajectories = {name: [] for name in self.leaders}  # [(t_s, r_hill, v_hill)]
        self.waiting_for = None  # the leaders a request waits for, once announced
        self.rigid = params.chaser_model == 'rigid_body'
        self.methods = {m.name: m for m in (FlybyMethod(), OptimalMethod(params, len(self.leaders)), SyncMethod())}
        self.method_flown = None  # the name of the method of the plan being flown: a re-plan keeps it
        self.phase = None  # mission/phase as last heard: the PLANNING request is served only in PLANNING

    # -- inputs ---------------------------------------------------------------------------------
    def on_event(self, event):
        """The supervisor's stamped transition to PLANNING plans at that time; its request lapses when the phase moves
        on (a respawned planner, fed the events' history, must not plan again from a PLANNING long past); HOLD and
        RETREAT forget every request and every method's plan (the plan after the fault's recovery is a first one,
        not a re-plan of the one given up). Guidance's re-aim is published."""
        to_phase = event_payloads.decode(event).to_phase if event.name == events.PHASE_CHANGED else None
        if to_phase == c.PHASE_PLANNING:
            self.request = (event.t, PLANNING_REQUEST)
            return self.try_plan()
        if to_phase is not None and self.request is not None and self.request[1] == PLANNING_REQUEST:
            self.request = self.waiting_for = None
        if to_phase in c.WAITING_PHASES:
            self.request = self.waiting_for = self.method_flown = None
            for method in self.methods.values():
                method.forget()
            return []
        refined = event_payloads.decode(event) if event.name == events.TARGET_REFINED else None
        if refined is not None and refined.x_g_hill_m is not None:
            v = refined
            grasp = GraspState(v.t_grasp_s, _array(v.x_g_hill_m), _array(v.v_g_hill_mps), _array(v.q_hill_from_body),
                               _array(v.omega_body_rad_s))
            return [AimUpdate(grasp, _array(v.x_ft_hill_m), _array(v.v_ft_hill_mps))]
        if self.method_flown is not None:  # guidance's replan request, the docking's start (methods.CaptureMethod)
            out = self.methods[self.method_flown].on_event(self, event)
            if out is not None:
                return out
        return []

    def on_phase(self, phase):
        """mission/phase (latched): a respawned planner is fed the events' history and live estimates in any order,
        and must not plan from a PLANNING long past before it has heard the phase moved on."""
        self.phase = phase
        return self.try_plan()

    def on_replan(self):
        """Plan again at the next target estimate."""
        self.request = (self.targets.latest_t, 'replan requested')
        return []

    def on_leader_event(self, leader, event):
        """An event of a leader's mission/events: its planner's plan_selected (a trajectory to come unless it is a
        fly-by) or plan_refused is its decision at that stamp."""
        if leader not in self.leader_decisions or event.name not in (events.PLAN_SELECTED, events.PLAN_REFUSED):
            return []
        decision = event_payloads.decode(event)
        has_trajectory = event.name == events.PLAN_SELECTED and decision.method not in (None, 'flyby')
        self.leader_decisions[leader].append((event.t, decision.t_start_s if has_trajectory else None))
        return self.try_plan()

    def on_leader_trajectory(self, leader, t_s, r_hill, v_hill):
        """A leader's planner/trajectory: its points' times t_s (K,) [s], r_hill, v_hill (K, 3)."""
        if leader in self.leader_trajectories:
            self.leader_trajectories[leader].append(tuple(np.array(a, dtype=float) for a in (t_s, r_hill, v_hill)))
        return self.try_plan()

    def on_chaser_estimate(self, t, r_hill, v_hill):
        self.chasers.add(t, (np.asarray(r_hill, dtype=float), np.asarray(v_hill, dtype=float)))
        return self.try_plan()

    def on_target_estimate(self, t, q_hill_from_body, omega_body, attitude_covariance_hill=None,
                           rate_covariance_body=None):
        """A target estimate (estimation/target/odom) with, if published, its attitude covariance about hill axes
        and rate covariance in body axes (3x3 each): the fly-by's re-aim check starts from them
        (flyby.reaim.ReaimModel)."""
        blocks = (None if attitude_covariance_hill is None or rate_covariance_body is None else
                  (np.asarray(attitude_covariance_hill, dtype=float), np.asarray(rate_covariance_body, dtype=float)))
        self.targets.add(t, (np.asarray(q_hill_from_body, dtype=float), np.asarray(omega_body, dtype=float), blocks))
        if self.method_flown is not None:  # the optimal approach's re-aim, the synchronized one's re-solve
            self.methods[self.method_flown].follow_up(self, t)
        return self.try_plan()

    # -- planning -------------------------------------------------------------------------------
    def try_plan(self):
        """Plan at the first target estimate stamped at or after the request, once the chaser estimates
        up to that stamp are in (the same estimates at any pace of the run)."""
        if self.request is None:
            return []
        t_request, why = self.request
        if why == PLANNING_REQUEST and self.phase != c.PHASE_PLANNING:
            return []
        waiting, t_leaders = self._leaders_decided(t_request)
        if waiting:
            if self.waiting_for == waiting:
                return []
            self.waiting_for = waiting
            return [self.event(t_request, 'OK', events.WAITING_FOR_LEADERS,
                                f'planning after the plans of {", ".join(waiting)}', {'leaders': ' '.join(waiting)})]
        target = self.targets.first_at_or_after(max(t_request, t_leaders))
        if target is None or self.chasers.latest_t < target[0]:
            return []
        self.request = None
        q_hill_from_body, omega_body, blocks = target[1]
        covariance_body = None if blocks is None else covariance_from_published(q_hill_from_body, *blocks)
        return self._plan(target[0], q_hill_from_body, omega_body, why, covariance_body)

    def _leader_decision(self, leader, t):
        """The leader's decision (t_plan, its trajectory or None) a plan at t goes by: the latest at or before t,
        else its first; None while it has none (or its trajectory has not come in)."""
        decisions = self.leader_decisions[leader]
        if not decisions:
            return None
        t_plan, t_start = ([d for d in decisions if d[0] <= t] or decisions[:1])[-1]
        if t_start is None:
            return t_plan, None
        for traj in self.leader_trajectories[leader]:
            if abs(traj[0][0] - t_start) < 1e-6:
                return t_plan, traj
        return None

    def _leaders_decided(self, t_request):
        """(the leaders still to decide, the latest plan time of the decided ones (-inf without leaders))."""
        decided = {name: self._leader_decision(name, t_request) for name in self.leaders}
        waiting = tuple(name for name, d in decided.items() if d is None)
        return waiting, max((d[0] for d in decided.values() if d is not None), default=-np.inf)

    def leader_obstacles(self, t, prediction):
        """The leaders' planned motion a plan at t keeps off (mutual.MovingObstacle, carried with the target after
        their end as a captured robot is), with the joint planner's separation margin."""
        flyby = self.params.flyby
        attitude = TargetMotion(prediction, flyby.boxes, flyby.mean_motion_rad_s).attitude
        obstacles = []
        for name in self.leaders:
            decision = self._leader_decision(name, t)
            if decision is not None and decision[1] is not None:
                t_s, r_hill, v_hill = decision[1]
                obstacles.append(MovingObstacle(name, t_s, r_hill, v_hill, self.params.leader_envelope_radius_m[name],
                                                ScpSettings.separation_margin_m, flyby.mean_motion_rad_s, attitude))
        return obstacles

    def plan_inputs(self, t, q_hill_from_body, omega_body, extended=False):
        """What a plan at the target estimate of time t starts from: the chaser's estimated state carried to t
        (eq 22) and the target motion predicted from the estimate over the grasp window (extended: and the
        extended window, as flyby.diagnostics.exhaustive_check needs)."""
        prediction = prediction_from_estimate(self.dynamics, self.params.flyby.mean_motion_rad_s, t, q_hill_from_body,
                                              omega_body, t + self.params.flyby.prediction_span_s(omega_body, extended))
        return self.chaser_at(t), prediction

    def chaser_at(self, t):
        """The chaser's estimated state (r_hill, v_hill stacked) carried to t by CW (eq 22)."""
        t_c, (r_c, v_c) = self.chasers.last_at_or_before(t) or self.chasers.first_at_or_after(t)
        return cw_coast(r_c, v_c, t - t_c, self.params.flyby.mean_motion_rad_s)

    def _plan(self, t, q_hill_from_body, omega_body, why, covariance_body=None):
        """Plan at the target estimate of time t (the plan time) by the method of planner.method (module doc);
        the outputs to publish. covariance_body: that estimate's 6x6 [dtheta_body, domega_body] covariance, if
        published (the fly-by's re-aim check)."""
        self.plans += 1
        name, reason, fallback = choose(self, omega_body)
        out, refusal = self.methods[name].plan(self, t, q_hill_from_body, omega_body, why, covariance_body, reason)
        if refusal is not None and fallback is not None:  # auto: no safe fly-by
            more, second = self.methods[fallback].plan(self, t, q_hill_from_body, omega_body, why, covariance_body,
                                                       f'auto: no safe fly-by ({refusal.reason})')
            out = out + more
            refusal = None if second is None else second._replace(reason=f'fly-by: {refusal.reason}; {second.reason}')
        return out if refusal is None else out + self._refuse(t, why, *refusal)

    def _refuse(self, t, why, reason, markers, planning_time_s):
        """plan_refused and the markers of what refused."""
        return [self.event(t, 'ERROR', events.PLAN_REFUSED, reason,
                           event_payloads.encode(event_payloads.PlanRefused(why, str(self.plans), planning_time_s))),
                PlanRefused(t, markers)]

    def method_chosen(self, t, method, reason):
        """method_chosen (the method flown from now on, and why)."""
        self.method_flown = method
        return self.event(t, 'OK', events.METHOD_CHOSEN, f'{method}: {reason}', {'method': method, 'reason': reason})

    def event(self, t, level, name, message, values):
        """An Event of this planner."""
        return Event(t, level, name, message, values, self.name)
