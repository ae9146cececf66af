"""What flyby_guidance's transport tests share (test_transport.py, test_transport_terminal.py):
matsunaga_orbit_advance's transport guidance on a given final estimate, planned from rest, arrived, and the estimates
fed to it."""

import dataclasses
import math
from pathlib import Path

import numpy as np

from flyby_guidance.damping import PostCaptureConfig
from flyby_guidance.transport.control import TransportControl, TransportGuidanceConfig, transport_body
from flyby_msgs_py.event_payloads import decode_values
from flyby_msgs_py.events import MASS_PROPERTIES_ESTIMATED
from flyby_planner.transport.model import TransportState
from flyby_sim.dynamics.attitude import body_point_state
from flyby_sim.dynamics.orbital import q_eci_from_body, q_hill_from_body
from flyby_sim.dynamics.rotation import quat_to_matrix
from flyby_sim.scenario import load_scenario

SCENARIO = Path(__file__).resolve().parents[1] / 'scenarios' / 'matsunaga_orbit_advance.yaml'
# The final estimate's values as the estimator's mass_properties_estimated event carries them (text).
ESTIMATE = decode_values(MASS_PROPERTIES_ESTIMATED, {
    'mass_kg': '20.2', 'mass_sigma_kg': '0.0', 'com_body_m': '[0.5, 0.0, 0.0]', 'com_sigma_m': '[0.0, 0.0, 0.0]',
    'principal_moments_kg_m2': '[1.5, 1.5, 2.0]', 'principal_moments_sigma_kg_m2': '[0.0, 0.0, 0.0]',
    'principal_axes_q': '[0.0, -0.7071067811865476, 0.0, 0.7071067811865476]'})


def control_for(planner=None, estimate=ESTIMATE, **changes):
    """matsunaga_orbit_advance's transport guidance (wheels of 0.1 N m and 1 N m s) on the final estimate given, its
    config's keys replaced by changes and its TransportConfig's by planner (a dict)."""
    sc = load_scenario(SCENARIO)
    body = transport_body(estimate, sc.chaser.mass_kg, sc.chaser_inertia, sc.thruster_layout,
                          sc.post_capture.transport.plume_cone_deg)
    config = TransportGuidanceConfig.from_scenario(sc)
    if planner:
        changes['planner'] = dataclasses.replace(config.planner, **planner)
    control = TransportControl(dataclasses.replace(config, **changes), sc.mean_motion_rad_s,
                               PostCaptureConfig.from_scenario(sc).gains, 0.1, 1.0)
    return sc, body, control


def until_planned(body, control):
    """Estimates at rest with the chaser's axes along hill's from t = 85 s until the plan or its refusal: the events."""
    control.start(85.0, body)
    q, r_chaser, t = np.array([0.0, 0.0, 0.0, 1.0]), np.array([10.0, 5.0, 5.0]) - body.com_body_m, 85.0
    events = []
    while control.plan is None and not control.done:
        events += control.command(t, r_chaser, np.zeros(3), q, np.zeros(3), np.zeros(3))[3]
        t += 0.1
    return events


def planned(estimate=ESTIMATE, **changes):
    """The control of test_transport_detumbles_then_plans_and_flies_the_pushes_on_the_estimate once planned, at rest
    with the chaser's axes along hill's (the estimate it planned from)."""
    _, body, control = control_for(estimate=estimate, **changes)
    until_planned(body, control)
    return body, control


def state_at(t, q=(0.0, 0.0, 0.0, 1.0), r=(1000.0, 0.0, 0.0), v=(0.0, 0.0, 0.0), omega=(0.0, 0.0, 0.0)):
    return TransportState(t, np.asarray(r, dtype=float), np.asarray(v, dtype=float), np.asarray(q, dtype=float),
                          np.asarray(omega, dtype=float))


P = 0.1  # guidance's control period on matsunaga_orbit_advance (the chaser IMU's 10 Hz) [s]


def estimate(control, t, r_com, v_com=(0.0, 0.0, 0.0), q_hill=(0.0, 0.0, 0.0, 1.0), omega=(0.0, 0.0, 0.0),
              h_wheels=(0.0, 0.0, 0.0)):
    """control.command of the chaser estimate whose combined CoM is at r_com moving at v_com (hill; the chaser's
    point -c of the body by seed 000 eq 8-9)."""
    q, omega = np.asarray(q_hill, dtype=float), np.asarray(omega, dtype=float)
    r_point, v_point = body_point_state(quat_to_matrix(q), omega, -control.body.com_body_m, control.n)
    return control.command(t, np.asarray(r_com, dtype=float) + r_point, np.asarray(v_com, dtype=float) + v_point, q,
                           omega, np.asarray(h_wheels, dtype=float))


def arrived(nav_position_sigma_m=0.01, **changes):
    """A planned control, its navigation's 1-sigma given (position_sigma_m, 10 um/s, a CoM of 0.1 mm), and the first
    estimate's stamp after its last burn and arrival on the grid: (body, control, t0, q_eci_from_body at rest there
    with the body's axes along hill's)."""
    body, control = planned(**changes)
    last_burn_end = max(b.t_start_s + b.duration_s for b in control.plan.burns)
    t0 = P * math.ceil(max(control.plan.t_arrival_s, last_burn_end) / P + 1.0)
    control.refine_com(t0, control.body.com_body_m.tolist(), nav_position_sigma_m, 1e-5)
    return body, control, t0, q_eci_from_body(t0, control.n, np.array([0.0, 0.0, 0.0, 1.0]))


def held(control, t, q_eci):
    """The attitude held inertially, in hill at t."""
    return q_hill_from_body(t, control.n, q_eci)
