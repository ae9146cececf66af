"""Guidance idles propulsion on the supervisor's node_error (flyby_guidance.guidance_core's module doc,
docs/runtime.md): no burn and no thrust from its arrival, the six-degree-of-freedom chaser's attitude held by the
wheels alone."""

from pathlib import Path

import numpy as np

from flyby_guidance.guidance import Maneuver
from flyby_guidance.guidance_core import GuidanceCore
from flyby_guidance.modes.interface import AttitudeCommandStamped
from flyby_guidance.params import GuidanceParams
from flyby_msgs_py import contract as c
from flyby_msgs_py import events, wiring
from flyby_msgs_py.core_guard import CoreGuard
from flyby_msgs_py.wire import Event, wire_event
from flyby_sim.dynamics.rotation import quat_from_axis_angle
from flyby_sim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'
X_FI, V_FI = np.array((-20.0, 0.0, 30.0)), np.array((0.05, 0.0, -0.1))
X_FT, V_FT = np.array((0.5, 2.9, 0.1)), np.array((0.0, 0.01, 0.19))


def _node_error(node, t=100.0):
    """A node's node_error as guidance reads it off mission/events (values as text)."""
    return wire_event(CoreGuard(node).fail(t, c.EST_CHASER_ODOM, ZeroDivisionError('injected')))


def _flying(scenario):
    """paper_flyby's guidance flying a plan of t = 60 s (its transfer burn commanded at 65.1 s)."""
    core = GuidanceCore(GuidanceParams.from_scenario(load_scenario(SCENARIOS / scenario)))
    core.on_flyby_target(813.0, X_FT, V_FT)
    core.on_flyby_initial(513.0, X_FI, V_FI)
    core.on_path(60.0)
    core.on_phase(c.PHASE_TERMINAL_APPROACH)
    return core


def test_the_supervisors_node_error_idles_the_burns_once_and_says_so():
    core = _flying('paper_flyby.yaml')
    r, v = np.array((50.0, 0.0, 0.0)), np.zeros(3)
    # Another node's node_error is the supervisor's to answer: guidance flies on.
    assert core.on_event(_node_error(wiring.PLANNER)) == []
    (idled,) = core.on_event(_node_error(wiring.SUPERVISOR))
    assert isinstance(idled, Event) and idled.level == 'ERROR' and idled.name == events.PROPULSION_IDLED
    assert idled.t == 100.0 and idled.source == 'flyby_guidance' and 'ZeroDivisionError: injected' in idled.message
    assert core.on_event(_node_error(wiring.SUPERVISOR, 101.0)) == []  # once
    # The transfer burn's estimate (65.1 s) commands nothing now.
    assert core.on_chaser_estimate(65.1, r, v) == []
    fresh = _flying('paper_flyby.yaml')
    assert any(isinstance(o, Maneuver) for o in fresh.on_chaser_estimate(65.1, r, v))


def test_the_rigid_chaser_holds_its_attitude_on_the_wheels_alone_once_propulsion_is_idle():
    """50 m out, outside the restriction sphere, body +x 3 deg off the line of sight, the wheels near their momentum
    limit: the pointing dumps their momentum with the thrusters' torque; idle, the pointing with the wheels alone,
    no force and no thruster torque."""
    r, q = np.array((50.0, 0.0, 0.0)), quat_from_axis_angle((0.0, 0.0, 1.0), np.pi + 0.05)
    commands = {}
    for idle in (False, True):
        core = _flying('paper_flyby_6dof.yaml')
        wheels = core.chaser.attitude.wheels
        core.chaser.h_wheels_n_m_s = np.full_like(core.chaser.h_wheels_n_m_s, 0.9 * wheels.max_momentum_n_m_s)
        if idle:
            core.on_event(_node_error(wiring.SUPERVISOR))
        out = [core.on_chaser_estimate(round(100.0 + 0.1 * k, 6), r, np.zeros(3), q, np.zeros(3)) for k in range(20)]
        commands[idle] = [o for each in out for o in each if isinstance(o, AttitudeCommandStamped)]
        assert len(commands[idle]) == len(out)
        if idle:  # nothing else: no burn, no event
            assert all(len(each) == 1 for each in out)
    assert any(np.any(cmd.thruster_torque_body_n_m != 0.0) for cmd in commands[False])
    for cmd in commands[True]:
        assert not np.any(cmd.thruster_torque_body_n_m) and cmd.force_body_n == (0.0, 0.0, 0.0)
    assert any(np.any(cmd.wheel_torque_n_m != 0.0) for cmd in commands[True])
    assert [cmd.t for cmd in commands[True]] == [cmd.t for cmd in commands[False]]  # one command every estimate


def test_a_chaser_estimate_waiting_for_its_target_estimate_is_not_stepped_once_propulsion_is_idle():
    """The transfer burn's estimate (65.1 s) waiting for the target estimate of its stamp (a re-aim), then the
    supervisor's node_error: that target estimate steps nothing, where without the error it commands the burn."""
    r, v = np.array((50.0, 0.0, 0.0)), np.zeros(3)
    q, omega = np.array((0.0, 0.0, 0.0, 1.0)), np.array((0.0, 0.0, 0.0873))
    stepped = {}
    for idle in (False, True):
        core = _flying('paper_flyby.yaml')
        assert core.flyby.params.refine_target  # paper_flyby's default
        core.flyby.guidance.wants_refined_target = lambda t: True  # every estimate re-aims: it waits
        assert core.on_chaser_estimate(65.1, r, v) == [] and len(core.flyby.waiting) == 1
        if idle:
            core.on_event(_node_error(wiring.SUPERVISOR))
        stepped[idle] = core.on_target_estimate(65.1, q, omega)
    assert any(isinstance(o, Maneuver) for o in stepped[False])
    assert stepped[True] == []
