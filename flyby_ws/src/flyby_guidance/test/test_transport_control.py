"""Guidance in TRANSPORT (issue 17, transport_control): the body it plans for from the final mass-property estimate,
the detumbling first, the plan once detumbled and navigated, the closed-loop push and spin-down."""

from pathlib import Path

import numpy as np
import pytest

from flyby_guidance.guidance_core import post_capture_config_from_scenario
from flyby_guidance.transport_control import (
    NAV_SETTLE_S,
    TransportControl,
    transport_body,
    transport_guidance_config_from_scenario,
)
from flyby_planner.transport import propagate
from flyby_sim.dynamics.actuators import allocate_wrench
from flyby_sim.dynamics.combined_body import combined_mass_properties, inertia_from_principal
from flyby_sim.scenario import load_scenario

SCENARIO = Path(__file__).resolve().parents[4] / 'scenarios' / 'matsunaga_orbit_advance.yaml'
# The final estimate's values as the estimator's mass_properties_estimated event carries them (text).
ESTIMATE = {'mass_kg': '20.2', 'com_body_m': '[0.5, 0.0, 0.0]', 'principal_moments_kg_m2': '[1.5, 1.5, 2.0]',
            'principal_axes_q': '[0.0, -0.7071067811865476, 0.0, 0.7071067811865476]'}


def _control():
    sc = load_scenario(SCENARIO)
    body = transport_body(ESTIMATE, sc.chaser.mass_kg, sc.chaser_inertia, sc.thruster_layout,
                          sc.post_capture.transport.plume_cone_deg)
    control = TransportControl(transport_guidance_config_from_scenario(sc, 0.1), sc.mean_motion_rad_s,
                               post_capture_config_from_scenario(sc).gains, 0.1)
    return sc, body, control


def test_seed004_the_planned_body_is_the_combined_one_less_the_thrusters_firing_at_the_target():
    sc, body, _ = _control()
    inertia_t = inertia_from_principal((1.5, 1.5, 2.0), (0.0, -0.7071067811865476, 0.0, 0.7071067811865476))
    assert inertia_t[0, 0] == pytest.approx(2.0) and inertia_t[2, 2] == pytest.approx(1.5)  # the axis along x
    props = combined_mass_properties(30.0, sc.chaser_inertia, 20.2, (0.5, 0.0, 0.0), inertia_t)
    assert body.mass_kg == pytest.approx(50.2) and body.com_body_m == pytest.approx(props.com_body_m)
    np.testing.assert_allclose(body.inertia_body_kg_m2, props.inertia_body_kg_m2)
    assert body.layout.count == 10 and not np.any(body.layout.force_directions_body[:, 0] < -0.5)


def test_transport_detumbles_then_plans_and_flies_the_pushes_on_the_estimate():
    """The damping law first (torque against the rate, the least side force the ten thrusters need, in pulses above
    the minimum impulse bit); then, at rest and navigated, the plan; a push's force is the one the estimate needs
    now along its direction, with no torque about the combined CoM."""
    sc, body, control = _control()
    control.start(85.0, body)
    q = np.array([0.0, 0.0, 0.0, 1.0])
    r_chaser = np.array([10.0, 5.0, 5.0]) - body.com_body_m
    omega = np.array([0.0, 0.01, -0.01])
    forces, torques = [], []
    for k in range(20):
        f, tau, u, events = control.command(85.0 + 0.1 * k, r_chaser, np.zeros(3), q, omega, np.zeros(3))
        forces.append(f)
        torques.append(tau)
        assert not events and np.all(u * omega >= 0.0)  # the wheels take the rate (the body feels -u)
    fired = [tau for tau in torques if np.any(tau)]
    assert fired and all(float(tau @ omega) < 0.0 for tau in fired)  # against the rate
    assert len(fired) < len(torques)  # pulses: the small couple is carried between them
    rest = np.zeros(3)
    t = 87.0
    while control.t_detumbled is None:
        control.command(t, r_chaser, np.zeros(3), q, rest, np.zeros(3))
        t += 0.1
    assert control.plan is None
    while control.plan is None:
        *_, events = control.command(t, r_chaser, np.zeros(3), q, rest, np.zeros(3))
        t += 0.1
    assert t >= 85.0 + NAV_SETTLE_S and events[0][1] == 'transport_planned'
    assert control.plan.conditions['position_error_m'] < 10.0
    # At the push, the state the plan predicts: the closed-loop force is the planned one (the same needed velocity).
    push = next(b for b in control.plan.burns if b.purpose == 'push')
    planned_at = propagate(body, control.plan_start, [b for b in control.plan.burns if b.t_start_s < push.t_start_s],
                           push.t_start_s, control.config.planner)
    force, torque = control._closed_loop_push(push.t_start_s - 0.1, planned_at, push, push.force_body_n,
                                              push.torque_body_n_m)
    np.testing.assert_allclose(torque, np.cross(body.com_body_m, force), atol=1e-12)  # none about the combined CoM
    assert not allocate_wrench(body.layout, force, torque).saturated
    # Up to the Coriolis term over the push, which the closed loop takes at once: 2 n |dv| m ~ 0.14 N here.
    np.testing.assert_allclose(force, push.force_body_n, atol=0.2)
    # The push commanded at the previous estimate acts over the period the estimate has not seen yet: asked for once.
    control.issued = (push.t_start_s - 0.2, force, torque)
    again, _ = control._closed_loop_push(push.t_start_s - 0.1, planned_at, push, push.force_body_n,
                                         push.torque_body_n_m)
    np.testing.assert_allclose(again, force - force * 0.1 / push.duration_s, atol=1e-9)
    control.issued = None
    # A spin-down flown on the estimate takes out the estimated I omega + h (the wheels' included) over the burn,
    # whatever the plan said.
    stop = next(b for b in control.plan.burns if b.purpose == 'slew_stop')
    spinning = planned_at._replace(omega_body=np.array([0.0, 0.0, 0.005]))
    h_wheels = np.array([0.01, 0.0, -0.02])
    force, torque = control._closed_loop_stop(stop.t_start_s - 0.1, spinning, stop, stop.force_body_n,
                                              stop.torque_body_n_m, h_wheels)
    np.testing.assert_allclose(torque - np.cross(body.com_body_m, force),
                               -(body.inertia_body_kg_m2 @ spinning.omega_body + h_wheels) / stop.duration_s,
                               atol=1e-9)
