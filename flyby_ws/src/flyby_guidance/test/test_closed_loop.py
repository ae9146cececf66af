"""The headless driver ends its runs by the graph's rules: a refused plan is NO_SAFE_PLAN, nothing fired."""

from pathlib import Path

from flyby_guidance.closed_loop import run_headless
from flyby_sim.scenario import load_scenario, scenario_from_dict

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'


def test_a_refused_plan_ends_in_no_safe_plan_with_its_reason():
    """A spin axis along hill y breaks condition (b): no fly-by exists, and the chaser stays put."""
    d = load_scenario(SCENARIOS / 'paper_flyby.yaml').to_dict()
    d['target']['initial_attitude'] = {'body_axis_along_hill': {'body': [0.0, 0.0, 1.0], 'hill': [0.0, 1.0, 0.0]}}
    run = run_headless(scenario_from_dict(d, name='spin along hill y'))
    s = run.summary
    assert s['outcome'] == 'NO_SAFE_PLAN' and s['final_phase'] == 'COMPLETE'
    assert s['phase_sequence'] == ['ESTIMATION', 'PLANNING', 'COMPLETE']
    assert s['end_reason'].startswith('no safe plan: ') and 'condition (b)' in s['end_reason']
    assert s['end_reason'].count('no safe plan') == 1
    assert run.burns == [] and s['delta_v_total_mps'] == 0.0 and s['maneuvers_executed'] == 0
    assert s['sim_time_s'] < 120.0  # the run ends at the refusal
