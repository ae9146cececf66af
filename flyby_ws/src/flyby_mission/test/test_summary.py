"""Summary figures from truth thrust samples, checked against the rocket equation by hand."""

from pathlib import Path

import numpy as np
import pytest

from flyby_mission.approach_figures import sync_figures, thrust_figures
from flyby_mission.run_truth import ChaserTruth, TargetTruth, ThrustTruth
from flyby_mission.summary import outcome_of, summarize
from flyby_sim.dynamics.constants import STANDARD_GRAVITY_M_S2 as G0_MPS2
from flyby_sim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'


def test_constant_burn_delta_v_and_fuel():
    t = np.arange(0.0, 10.0 + 1e-9, 0.05)
    force = np.zeros((len(t), 3))
    force[21:41] = [10.0, 0.0, 0.0]  # 1 s at 10 N
    r = np.tile([50.0, 0.0, 0.0], (len(t), 1))
    dv, fuel, inside = thrust_figures(t, force, r, 100.0, 220.0, 15.0)
    fuel_exact = 10.0 * 1.0 / (220.0 * G0_MPS2)
    assert fuel == pytest.approx(fuel_exact, rel=1e-9)
    assert dv == pytest.approx(220.0 * G0_MPS2 * np.log(100.0 / (100.0 - fuel_exact)), rel=1e-9)
    assert inside is False
    r[30] = [10.0, 0.0, 0.0]
    assert thrust_figures(t, force, r, 100.0, 220.0, 15.0)[2] is True


def test_outcomes():
    assert outcome_of('interrupted', ['ESTIMATION']) == 'INTERRUPTED'
    assert outcome_of('error: node x exited with code 1', []) == 'ERROR'
    assert outcome_of('phase COMPLETE', ['FLYBY', 'CAPTURE', 'COMPLETE']) == 'CAPTURE'
    assert outcome_of('phase COMPLETE', ['FLYBY', 'ESCAPE', 'COMPLETE']) == 'ESCAPE'
    assert outcome_of('phase ABORTED', ['FLYBY', 'ABORTED']) == 'ABORTED'
    assert outcome_of('time_limit', []) == 'TIME_LIMIT'


def test_outcomes_of_design_section_10():
    assert outcome_of('phase COMPLETE', ['ESTIMATION', 'PLANNING', 'COMPLETE'], refused=True) == 'NO_SAFE_PLAN'
    # A refusal of a later replan, after a plan was flown, is not NO_SAFE_PLAN.
    assert outcome_of('phase COMPLETE', ['PLANNING', 'TERMINAL_APPROACH', 'FLYBY', 'ESCAPE', 'COMPLETE'],
                      refused=True) == 'ESCAPE'
    assert outcome_of('phase COMPLETE', ['FLYBY', 'CAPTURE', 'COMPLETE'], collided=True) == 'COLLISION'
    assert outcome_of('interrupted', ['FLYBY'], collided=True) == 'COLLISION'


def _truth_through(x_hill_m, capture_at=None):
    """Truth of a chaser moving along hill x at 0.1 m/s past a target at rest in hill (identity attitude)."""
    t = np.arange(0.0, 100.0 + 1e-9, 0.05)
    position = np.column_stack((x_hill_m(t), np.zeros_like(t), np.zeros_like(t)))
    chaser = ChaserTruth(t, position, np.gradient(position, t, axis=0))
    target = TargetTruth(t, np.tile((0.0, 0.0, 0.0, 1.0), (len(t), 1)), np.zeros((len(t), 3)))
    thrust = ThrustTruth(t, np.zeros((len(t), 3)))
    phases = ['ESTIMATION', 'PLANNING', 'TERMINAL_APPROACH', 'TRAJECTORY_ADJUST', 'FLYBY']
    events = []
    if capture_at is not None:
        phases += ['CAPTURE', 'COMPLETE']
        events = [{'t': capture_at, 'level': 'OK', 'name': 'phase_changed', 'message': 'FLYBY -> CAPTURE: capture',
                   'values': {'from': 'FLYBY', 'to': 'CAPTURE', 't_grasp_s': repr(capture_at)}, 'hardware_id': ''}]
    return chaser, target, thrust, phases, events


def test_collision_is_contact_in_the_truth_before_any_capture():
    sc = load_scenario(SCENARIOS / 'paper_flyby.yaml')  # a 3 m box about the centre of mass, envelope 0.5 m
    through = _truth_through(lambda t: 10.0 - 0.1 * t)  # from 10 m to 0 m: through the box
    s = summarize(*through, sc, 'phase COMPLETE')
    assert s['outcome'] == 'COLLISION' and s['min_clearance_m'] < 0.0
    past = _truth_through(lambda t: 10.0 - 0.05 * t)  # stops 5 m out: 3 m of clearance
    assert summarize(*past, sc, 'time_limit')['outcome'] == 'TIME_LIMIT'
    # Held after a capture at 30 s, the chaser may touch the body it holds: not a collision.
    held = _truth_through(lambda t: np.maximum(10.0 - 0.1 * t, 1.9), capture_at=30.0)
    s = summarize(*held, sc, 'phase COMPLETE')
    assert s['outcome'] == 'CAPTURE' and s['min_clearance_m'] < 0.0
    assert s['phase_sequence'][-2:] == ['CAPTURE', 'COMPLETE']


def test_the_least_clearance_time_is_the_first_of_its_plateau():
    """Attached after the grasp the clearance is flat to round-off: the summary and analyze_bag, computing the same
    gaps by two routes, take the first sample within CLEARANCE_TIE_M of the least, not either's argmin."""
    from flyby_mission.approach_figures import least_clearance_index
    assert least_clearance_index([0.5, 0.3, 0.3 + 1e-12, 0.3 - 1e-12, 0.4]) == 1
    assert least_clearance_index([0.5, 0.4, 0.3, 0.3 + 2e-6]) == 2


def test_sync_figures_peaks_by_phase_and_the_relative_attitude_drift_against_a_hand_case():
    """Issue 15's keys: per phase the peak of each step's mean force and torque (a step counted in the phase it ends
    in), and the largest drift of the chaser's attitude relative to the target's from the start of ORBITING to the
    grasp: the target spins at 0.3 rad/s about z, the chaser turns with it and drifts by 0.1 deg/s about x from the
    start of ORBITING (10 s), so 1 deg at the grasp (20 s), whatever happened before."""
    from scipy.spatial.transform import Rotation

    t = np.arange(0.0, 25.0 + 1e-9, 0.5)
    q_target = Rotation.from_rotvec(np.outer(0.3 * t, (0.0, 0.0, 1.0)))
    drift = np.radians(0.1) * np.clip(t - 10.0, 0.0, None)
    early = np.radians(5.0) * (t < 10.0)  # before stage 3 the relative attitude may be anything
    q_chaser = q_target * Rotation.from_rotvec(np.outer(drift + early, (1.0, 0.0, 0.0)))
    chaser = ChaserTruth(t, np.zeros((len(t), 3)), np.zeros((len(t), 3)), q_chaser.as_quat())
    target = TargetTruth(t, q_target.as_quat(), np.zeros((len(t), 3)))
    force = np.zeros((len(t), 3))
    force[t == 5.0] = (0.0, 30.0, 0.0)  # SYNC_APPROACH
    force[t == 10.0] = (140.0, 0.0, 0.0)  # the last step of SYNC_APPROACH: ends at 10 s
    force[t == 12.0] = (0.0, 0.0, 120.0)  # ORBITING
    torque = np.zeros((len(t), 3))
    torque[t == 15.0] = (0.0, 0.5, 0.0)
    events = [{'t': 0.0, 'name': 'plan_selected', 'values': {'method': 'sync'}},
              {'t': 0.0, 'name': 'phase_changed', 'values': {'to': 'SYNC_APPROACH'}},
              {'t': 10.0, 'name': 'phase_changed', 'values': {'to': 'ORBITING'}},
              {'t': 20.0, 'name': 'phase_changed', 'values': {'to': 'CAPTURE'}}]
    out = sync_figures(chaser, target, ThrustTruth(t, force, torque), events, 20.0)
    assert out['peak_force_n_by_phase'] == {'SYNC_APPROACH': 140.0, 'ORBITING': 120.0, 'CAPTURE': 0.0}
    assert out['peak_thruster_torque_n_m_by_phase'] == {'SYNC_APPROACH': 0.0, 'ORBITING': 0.5, 'CAPTURE': 0.0}
    assert out['relative_attitude_drift_max_deg'] == pytest.approx(1.0, abs=1e-9)
    events[0]['values']['method'] = 'optimal'
    assert set(sync_figures(chaser, target, ThrustTruth(t, force, torque), events, 20.0).values()) == {None}


def test_after_the_arms_lock_the_pair_keeps_the_locks_masses():
    """The simulator welds the pair at the arm's lock (grasp_damped; t = 0 for a start attached) into one rigid body
    whose CoM and inertia stay the lock's while its propellant burns (chaser_body.SixDofChaser's com_body_m): the
    truth's pair keeps the chaser's mass at the lock, or its CoM would be a point of the body off the plant's, turning
    with it (on paper_flyby_transport 2.8 mm and 0.005 N s of the judged momentum). Before the lock the chaser's mass
    is less the fuel burned by then."""
    from flyby_mission.post_capture_figures import post_capture_truth
    from flyby_mission.run_events import lock_time
    from flyby_mission.run_truth import WheelTruth

    sc = load_scenario(SCENARIOS / 'paper_flyby_transport.yaml')
    t = np.arange(0.0, 10.0 + 1e-9, 1.0)
    n_thrusters = len(sc.chaser.thrusters.layout)
    chaser = ChaserTruth(t, np.zeros((len(t), 3)), np.zeros((len(t), 3)), np.tile((0.0, 0.0, 0.0, 1.0), (len(t), 1)),
                         np.zeros((len(t), 3)))
    target = TargetTruth(t, np.tile((0.0, 0.0, 0.0, 1.0), (len(t), 1)), np.zeros((len(t), 3)),
                         np.tile((3.0, 0.0, 0.0), (len(t), 1)), np.zeros((len(t), 3)))
    thrusters = np.zeros((len(t), n_thrusters))
    thrusters[:, 0] = 10.0  # one thruster at 10 N all along: 10 N s a step
    thrust = ThrustTruth(t, np.zeros((len(t), 3)), np.zeros((len(t), 3)), thrusters)
    wheels = WheelTruth(t, np.zeros((len(t), 3)))
    burnt = 10.0 / (sc.chaser.thrusters.isp_s * G0_MPS2)  # [kg] a step
    events = [{'t': 4.0, 'name': 'grasp_damped', 'values': {}}]
    assert lock_time(events, sc) == 4.0 and lock_time([], sc) is None
    _, _, _, bodies = post_capture_truth(chaser, target, wheels, thrust, sc, lock_time(events, sc))
    masses = [bodies(k)[0].mass_kg for k in range(len(t))]
    np.testing.assert_allclose(masses, sc.chaser.mass_kg - burnt * np.minimum(t, 4.0), rtol=1e-12)
    _, _, _, bodies = post_capture_truth(chaser, target, wheels, thrust, sc)
    assert bodies(10)[0].mass_kg == pytest.approx(sc.chaser.mass_kg - 10.0 * burnt, rel=1e-12)
    attached = load_scenario(SCENARIOS / 'matsunaga_orbit_advance.yaml')
    assert lock_time([], attached) == 0.0
