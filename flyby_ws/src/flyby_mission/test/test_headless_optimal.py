"""The headless loop flies seed 003 Table 1's case by the optimization-based approach (docs/optimal.md): planned by SCP
from the estimates, tracked with continuous thrust by the six-degree-of-freedom chaser, captured at the grasp."""

from pathlib import Path

import pytest

from flyby_mission.headless import run_headless
from flyby_mission.summary import format_summary
from flyby_sim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'


@pytest.fixture(scope='module')
def jacobsen():
    return run_headless(load_scenario(SCENARIOS / 'jacobsen_optimal.yaml'))


def test_jacobsen_optimal_captures_within_table_1s_time_and_acceleration(jacobsen):
    s = jacobsen.summary
    print(format_summary(s))
    assert s['outcome'] == 'CAPTURE', s['end_reason']
    assert s['method'] == 'optimal'
    assert s['phase_sequence'] == ['ESTIMATION', 'PLANNING', 'OPTIMAL_APPROACH', 'CAPTURE', 'COMPLETE']
    # seed 003 Table 1: 58.9 s, 0.138 m/s^2 (truth: the net thrust over the mass)
    assert s['approach_time_s'] <= 58.9 + 1e-9
    assert s['peak_acceleration_mps2'] <= 0.138
    # the manipulator's tolerances, from the truth at the grasp time (seed 1 flies 0.87 cm and 0.50 mm/s)
    assert s['capture_position_error_m'] < 0.10 and s['capture_velocity_error_mps'] < 0.010
    # the least-fuel plan flown: 2.703 m/s on seed 1, 6.1 % above the least found with keep-out and the plume rule
    # (2.549 m/s, docs/optimal.md "Least delta-v"); 3.075 m/s before the least-fuel mode
    assert s['delta_v_total_mps'] < 2.75
    assert s['min_clearance_m'] > 0.0
    # the plume rule on the net force, from the truth: nothing measurable away from the target within 5 m (the
    # estimate's error and one control period's motion leave about 1e-3 N s)
    assert s['plume_impulse_away_n_s'] < 0.01
    names = [e['name'] for e in jacobsen.events]
    assert names.count('method_chosen') == 1 and 'replan_requested' not in names
    assert 'late_command' not in names and 'burn_started' not in names  # flown by the wrench path alone
