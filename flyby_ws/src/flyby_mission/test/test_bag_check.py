"""The second route of scripts/analyze_bag.py, piece by piece on made-up data (test/test_run_mission*.py run it on
real bags)."""

import numpy as np

from flyby_mission.bag_check import (
    TOLERANCES,
    aimed_offset,
    axes_angle_deg,
    box_clearance,
    compare,
    docking_offset,
    first_sample_at_or_after,
    phase_entered,
)
from flyby_msgs_py import contract as c
from flyby_msgs_py import events


def test_box_clearance_outside_and_inside():
    r = np.array([[3.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    gaps = box_clearance(r, np.array([0.0, 0.0, 0.0, 1.0]), [[0.0, 0.0, 0.0]], [[2.0, 2.0, 2.0]], 0.5)
    assert np.allclose(gaps, [1.5, -1.5])  # 2 m from the face less the envelope; 1 m deep inside less it


def test_box_clearance_turns_the_point_into_body_axes():
    q_hill_from_body = np.array([0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4)])  # 90 deg about z
    gaps = box_clearance(np.array([[0.0, 3.0, 0.0]]), q_hill_from_body, [[0.0, 0.0, 0.0]], [[4.0, 1.0, 1.0]], 0.0)
    assert np.allclose(gaps, [1.0])  # hill +y is body +x, along the box's 4 m side


def test_events_read_by_name():
    log = [{'t': 5.0, 'name': events.PHASE_CHANGED, 'values': {'to': c.PHASE_GRASP}},
           {'t': 6.0, 'name': events.DOCKING_STARTED, 'values': {'offset_m': '0.25'}}]
    assert phase_entered(log, c.PHASE_GRASP) == 5.0 and phase_entered(log, c.PHASE_DAMPING) is None
    assert docking_offset(log) == 0.25 and docking_offset(log[:1]) is None


def test_first_sample_at_or_after():
    t = np.array([0.0, 0.5, 1.0])
    assert first_sample_at_or_after(t, 0.5) == 0.5
    assert first_sample_at_or_after(t, 0.6) == 1.0
    assert first_sample_at_or_after(t, 2.0) == 2.0


def test_aimed_offset_is_the_last_targets_range_less_the_grasp_points():
    class Series:
        t = np.array([1.0, 2.0])
        position = np.array([[0.0, 0.0, 3.0], [0.0, 4.0, 0.0]])
    assert aimed_offset(Series, np.array([0.0, 3.0, 0.0])) == 1.0
    assert aimed_offset(None, np.zeros(3)) is None


def test_compare_by_tolerance():
    summary = {'t_grasp_s': 10.0, 'fuel_used_kg': 0.1, 'maneuvers_executed': 3, 'flyby_offset_m': None}
    recomputed = {'t_grasp_s': 10.0005, 'fuel_used_kg': 0.1 + 2e-6, 'maneuvers_executed': 3, 'flyby_offset_m': None}
    rows = {key: agrees for key, _, _, agrees in compare(summary, recomputed, TOLERANCES)}
    assert rows == {'t_grasp_s': True, 'fuel_used_kg': False, 'maneuvers_executed': True, 'flyby_offset_m': True}


def test_axes_angle_ignores_the_sign_of_an_axis():
    assert axes_angle_deg([0.0, 0.0, 0.0, 1.0], np.diag([1.0, -1.0, 1.0])) == 0.0
