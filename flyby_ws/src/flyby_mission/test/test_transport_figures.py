"""The transport's figures at transport_complete by both routes, the summary's (post_capture_figures.transport_figures)
and analyze_bag's (bag_check.transport), against a hand computation: a held pair turning as one rigid body at a known
rate, whose own angular momentum about the combined CoM is I_combined omega by the parallel-axis theorem (scipy's
rotations), while its wheels hold what they are given; the settle time and counts from the events."""

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from flyby_mission import bag_check
from flyby_mission.post_capture_figures import TRANSPORT_KEYS, transport_figures
from flyby_mission.run_truth import ChaserTruth, TargetTruth, WheelTruth
from flyby_msgs_py import bag as fb
from flyby_msgs_py import contract as c
from flyby_msgs_py import events as ev
from flyby_msgs_py.convert.sensors import joint_state_cdr
from flyby_sim.scenario import load_scenario

SC = load_scenario(Path(__file__).resolve().parents[4] / 'scenarios' / 'matsunaga_orbit_advance.yaml')
T = np.array([0.0, 1.0, 2.0])
ROT_C = Rotation.from_euler('xyz', [0.3, -0.2, 0.5])  # q_hill_from_chaser_body
ROT_T = ROT_C * Rotation.from_euler('xyz', [0.1, 0.4, -0.3])  # q_hill_from_target_body, held
X_S_BODY_M = np.array([0.9, 0.1, -0.2])  # the target's CoM from the chaser's, chaser_body
OFFSET_HILL_M = np.array([0.3, -0.4, 0.0])  # the combined CoM from the goal: 0.5 m
V_CM_HILL_MPS = np.array([2e-6, 0.0, -1e-6])  # relative to hill, the goal's circular motion


def combined_momentum(omega_hill):
    """I_combined omega [kg m^2/s], hill axes: each body's inertia turned into hill plus m |d|^2 E - m d d^T about
    the combined CoM."""
    m_c, m_t = SC.chaser.mass_kg, SC.target.mass_kg
    d = ROT_C.apply(X_S_BODY_M)
    inertia = np.zeros((3, 3))
    for rot, body_inertia, mass, arm in ((ROT_C, SC.chaser_inertia, m_c, -m_t / (m_c + m_t) * d),
                                         (ROT_T, SC.target_inertia, m_t, m_c / (m_c + m_t) * d)):
        r = rot.as_matrix()
        inertia += r @ body_inertia @ r.T + mass * (arm @ arm * np.eye(3) - np.outer(arm, arm))
    return inertia @ omega_hill


def held_pair(omega_hill, h_wheels):
    """(ChaserTruth, TargetTruth, WheelTruth) of the pair turning at omega_hill (inertial rate, hill axes) about its
    CoM at the goal's OFFSET_HILL_M moving at V_CM_HILL_MPS, the same at every stamp of T, each wheel holding
    h_wheels [N m s] (its speed relative to the body h / J - a . omega)."""
    m_c, m_t = SC.chaser.mass_kg, SC.target.mass_kg
    omega_orbit = np.array([0.0, -SC.mean_motion_rad_s, 0.0])  # hill's rate, seed 000 eq 11
    r_cm = np.asarray(SC.post_capture.transport.goal_hill_m) + OFFSET_HILL_M
    v_cm = V_CM_HILL_MPS + np.cross(omega_orbit, r_cm)
    d = ROT_C.apply(X_S_BODY_M)
    states = []
    for arm in (-m_t / (m_c + m_t) * d, m_c / (m_c + m_t) * d):
        r = r_cm + arm
        states.append((r, v_cm + np.cross(omega_hill, arm) - np.cross(omega_orbit, r)))
    (r_c, v_c), (r_t, v_t) = states
    w = SC.chaser.wheels
    axes = np.asarray(w.axes, dtype=float) / np.linalg.norm(w.axes, axis=1)[:, None]
    speed = np.asarray(h_wheels) / w.spin_inertia_kg_m2 - axes @ ROT_C.inv().apply(omega_hill)
    n = len(T)
    chaser = ChaserTruth(T, np.tile(r_c, (n, 1)), np.tile(v_c, (n, 1)), np.tile(ROT_C.as_quat(), (n, 1)),
                         np.tile(ROT_C.inv().apply(omega_hill), (n, 1)))
    target = TargetTruth(T, np.tile(ROT_T.as_quat(), (n, 1)), np.tile(ROT_T.inv().apply(omega_hill), (n, 1)),
                         np.tile(r_t, (n, 1)), np.tile(ROT_T.inv().apply(v_t), (n, 1)))
    return chaser, target, WheelTruth(T, np.tile(speed, (n, 1)))


def transport_events(complete=True):
    """TRANSPORT from t = 0, a plan, a correction, a second plan (arrival 1.2 s, bound 5 s) and two terminal
    firings; transport_complete at t = 2 s."""
    def event(t, name, **values):
        return {'t': t, 'level': 'OK', 'name': name, 'message': '', 'values': values, 'hardware_id': 'flyby_guidance'}
    plan = dict(burns=2, fuel_kg=0.01, predicted_position_error_m=0.1, predicted_momentum_error_n_s=1e-3,
                predicted_angular_momentum_kg_m2_s=1e-3)
    out = [event(0.0, ev.PHASE_CHANGED, **{'from': c.PHASE_MASS_ESTIMATION, 'to': c.PHASE_TRANSPORT}),
           event(0.0, ev.TRANSPORT_PLANNED, t_arrival_s=0.5, settle_bound_s=10.0, **plan),
           event(0.2, ev.TRANSPORT_CORRECTION, miss_m=1.0, impulse_n_s=0.1),
           event(0.6, ev.TRANSPORT_PLANNED, t_arrival_s=1.2, settle_bound_s=5.0, **plan),
           event(1.5, ev.TRANSPORT_TERMINAL, impulse_n_s=0.01, horizon_s=100.0, predicted_momentum_n_s=1e-3,
                 predicted_position_m=0.2),
           event(1.7, ev.TRANSPORT_TERMINAL, impulse_n_s=0.01, horizon_s=100.0, predicted_momentum_n_s=1e-3,
                 predicted_position_m=0.2)]
    if complete:
        out.append(event(2.0, ev.TRANSPORT_COMPLETE, t_arrival_s=1.2, settle_bound_s=5.0))
    return out


def bag_route(tmp_path, chaser, target, wheels, events):
    """bag_check.transport of the truth with the wheels written to a new bag in tmp_path, as the simulator records
    them."""
    topic = c.absolute(c.SIM_CHASER_WHEELS)
    bag_dir = tmp_path / f'bag{len(list(tmp_path.iterdir()))}'
    with fb.BagWriter(bag_dir, {topic: c.TOPIC_TYPES[c.SIM_CHASER_WHEELS]}, 10**9, fsync=False) as writer:
        for t, speed in zip(wheels.t, wheels.velocity, strict=True):
            writer.write(topic, int(t * 1e9), joint_state_cdr(t, 'chaser_body', [f'w{i}' for i in range(len(speed))],
                                                              speed))
    return bag_check.transport(bag_dir, SC, chaser, target, events, lambda _t: 0.0)


@pytest.fixture(params=['summary', 'bag'])
def route(request, tmp_path):
    """The figures of (chaser, target, wheels, events) by one route."""
    if request.param == 'summary':
        return lambda *truth: transport_figures(*truth[:3], None, truth[3], SC)
    return lambda *truth: bag_route(tmp_path, *truth)


def test_the_body_angular_momentum_is_i_omega_with_the_wheels_left_out(route):
    """The pair turns at a known rate and the wheels hold the opposite momentum: the whole (body and wheels) holds
    next to none, the body alone I omega, the wheels as much again."""
    axis = np.array([0.2, -0.5, 0.84]) / np.linalg.norm([0.2, -0.5, 0.84])
    omega_hill = 0.05 / np.linalg.norm(combined_momentum(axis)) * axis  # I omega of 0.05 kg m^2/s
    body = combined_momentum(omega_hill)
    h_wheels = -ROT_C.inv().apply(body)  # the wheels' axes are chaser_body's
    np.testing.assert_allclose(np.asarray(SC.chaser.wheels.axes), np.eye(3))
    figures = route(*held_pair(omega_hill, h_wheels), transport_events())
    assert figures['transport_final_angular_momentum_kg_m2_s'] == pytest.approx(0.05, rel=1e-9)
    assert figures['transport_wheel_momentum_n_m_s'] == pytest.approx(0.05, rel=1e-9)
    assert figures['transport_wheel_momentum_share'] == pytest.approx(
        np.max(np.abs(h_wheels)) / SC.chaser.wheels.max_momentum_n_m_s, rel=1e-9)
    assert figures['transport_final_position_error_m'] == pytest.approx(0.5, rel=1e-9)
    mass = SC.chaser.mass_kg + SC.target.mass_kg
    assert figures['transport_orbital_momentum_error_n_m_s'] == pytest.approx(
        mass * np.linalg.norm(V_CM_HILL_MPS), rel=1e-6)
    assert figures['transport_conditions_met'] is True
    assert figures['transport_settle_time_s'] == pytest.approx(0.8)  # from the flown plan's arrival, 1.2 s
    assert figures['transport_settle_bound_s'] == 5.0
    assert figures['transport_replans'] == 1 and figures['transport_terminal_firings'] == 2


def test_wheels_beyond_their_share_miss_the_conditions_and_leave_the_body_figure_alone(route):
    """A body at rest in the goal's frame whose wheels hold momentum: none of it is the body's; above
    post_capture.transport.wheel_momentum_share of a wheel's capacity the conditions are missed."""
    capacity, share = SC.chaser.wheels.max_momentum_n_m_s, SC.post_capture.transport.wheel_momentum_share
    omega_hill = np.zeros(3)
    for held, met in ((share - 0.05, True), (share + 0.05, False)):
        figures = route(*held_pair(omega_hill, [0.0, -held * capacity, 0.0]), transport_events())
        assert figures['transport_final_angular_momentum_kg_m2_s'] == pytest.approx(0.0, abs=1e-9)  # 1 km out
        assert figures['transport_wheel_momentum_n_m_s'] == pytest.approx(held * capacity, rel=1e-9)
        assert figures['transport_wheel_momentum_share'] == pytest.approx(held, rel=1e-9)
        assert figures['transport_conditions_met'] is met


def test_without_transport_complete_no_settle_time_and_the_conditions_are_not_met(route):
    figures = route(*held_pair(np.zeros(3), [0.0, 0.0, 0.0]), transport_events(complete=False))
    assert figures['transport_conditions_met'] is False
    assert figures['transport_settle_time_s'] is None
    assert figures['transport_settle_bound_s'] == 5.0  # the last plan's


def test_the_summary_and_the_bag_route_have_the_same_keys():
    assert set(bag_check.TRANSPORT_TOLERANCES) <= set(TRANSPORT_KEYS)
    assert set(TRANSPORT_KEYS) - set(bag_check.TRANSPORT_TOLERANCES) == {
        'transport_goal_hill_m', 'transport_fuel_kg', 'transport_impulses', 'transport_time_s'}
