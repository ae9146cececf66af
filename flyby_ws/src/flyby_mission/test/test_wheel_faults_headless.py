"""A wheel fault headless: paper_flyby_6dof's wheel 2 (body z) failed 10 s into the terminal approach is named by the
wheel monitor, answered ``reallocate`` (docs/faults.md's FMECA), guidance commands it nothing from then on and the
thrusters' couples hold its axis outside the restriction sphere, and the fly-by captures. Before the reallocation
(an ``abort``) the same run ended ABORTED."""

from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

from flyby_mission.headless import HeadlessGraph, run_headless
from flyby_msgs_py import event_payloads, events
from flyby_sim.scenario import scenario_from_dict

REPO = Path(__file__).resolve().parents[4]


@pytest.mark.slow
def test_a_wheel_failed_in_the_approach_is_reallocated_to_the_thrusters_and_the_fly_by_captures():
    d = yaml.safe_load((REPO / 'scenarios' / 'paper_flyby_6dof.yaml').read_text())
    d['faults'] = [{'type': 'wheel_failed', 'index': 2, 'start_phase': 'TERMINAL_APPROACH', 'delay_s': 10.0}]
    scenario = scenario_from_dict(d, name='wheel_failed')
    graph = HeadlessGraph(scenario)
    run = run_headless(scenario, graph=graph)
    summary = run.summary
    (detected,) = summary['faults_detected']
    assert (detected['kind'], detected['component'], detected['isolated']) == ('wheel_torque_deficit', 'wheels [2]',
                                                                               True)
    assert detected['delay_s'] < 2.0
    (response,) = summary['fault_responses']
    assert (response['response'], response['phase']) == ('reallocate', 'TERMINAL_APPROACH')
    (out,) = [e for e in run.events if e['name'] == events.WHEELS_REALLOCATED]
    assert event_payloads.decode_values(out['name'], out['values']).wheels == (2,)  # as the wire carries it
    assert summary['outcome'] == 'CAPTURE' and not summary['cam_fired']
    assert not summary['thrust_inside_restriction_sphere']
    # the thrusters hold body z outside the sphere: the pointing within the nominal run's 2.6 deg there
    t = np.array(graph.truth.t, dtype=float)
    r = np.array(graph.truth.r)
    sphere_m = scenario.planner.restriction_sphere_radius_m + 1.0
    outside = (t > detected['t_s'] + 5.0) & (np.linalg.norm(r, axis=1) > sphere_m)
    axis = Rotation.from_quat(np.array(graph.truth.q_chaser)[outside]).apply((1.0, 0.0, 0.0))
    sight = -r[outside] / np.linalg.norm(r[outside], axis=1)[:, None]
    error_deg = np.degrees(np.arccos(np.clip(np.sum(axis * sight, axis=1), -1.0, 1.0)))
    assert outside.sum() > 1000 and error_deg.max() < 3.0
