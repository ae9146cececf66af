"""The headless driver ends its runs by the graph's rules: a refused plan is NO_SAFE_PLAN, nothing fired."""

from pathlib import Path

from flyby_guidance.guidance_core import GuidanceCore
from flyby_guidance.params import GuidanceParams
from flyby_mission.headless import HeadlessGraph, run_headless
from flyby_sim.scenario import load_scenario, scenario_from_dict
from flyby_testing import envelope_run_569

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


def _envelope_run_569():
    """Run 569 of the envelope campaign with its run seed, flown 1200 s, planned as the campaign did: without the
    re-aim check, which refuses the arc these tests need guidance to face (test_envelope_run_569_the_reaimed_...)."""
    d = load_scenario(SCENARIOS / 'paper_flyby.yaml').to_dict()
    envelope_run_569(d)
    d['planner']['reaim_check'] = False
    d['seed'] = 2056802005
    d['simulation']['duration_s'] = 1200.0
    return d


def test_an_unsafe_reaimed_arc_is_never_flown():
    """Envelope run 569: an 8.2 deg/s spin about the intermediate principal axis, an unstable tumble. The plan, from
    the estimate at 125 s, passes 0.136 m from the +y panel; the estimates of the adjusting phase show the real
    passage through that panel. Guidance used to re-aim onto it (COLLISION, 0.35 m deep, 25 s before the grasp);
    now its gate (plan.check_passage on every re-aimed arc, 3 sigma of each estimate's own covariance) refuses
    that arc at every re-aim and keeps the planned one, which it still finds clear: the chaser coasts past the
    panel and, the grasp point elsewhere, escapes (or is turned away by the independent monitor's CAM)."""
    d = _envelope_run_569()
    run = run_headless(scenario_from_dict(d, name='envelope run 569'))
    s = run.summary
    refused = [e for e in run.events if e['name'] == 'target_refined' and e['level'] == 'WARN']
    assert refused and all('panel_plus_y' in e['message'] and 'keeping the aim' in e['message'] for e in refused)
    assert not any(e['name'] == 'target_refined' and e['level'] == 'OK' for e in run.events)
    # The passage clears the panel by 0.10 m: the independent monitor may see it as contact and fire its CAM
    # (docs/faults.md), which leaves it clear too.
    assert (s['outcome'] == 'ESCAPE' or s['cam_fired']) and s['min_clearance_m'] > 0.0, s
    assert s['cam_fired'] or not s['thrust_inside_restriction_sphere']  # a CAM may fire there; guidance never


def test_without_a_safe_arc_guidance_stops_and_the_supervisor_escapes():
    """The same run with a guidance whose filter model admits unmodelled torques of 1e-6 N^2 m^2 s that the plan
    did not (the planner, which now weighs its own predicted uncertainty, would not plan this arc with them): the
    estimates' own uncertainty, propagated to the passage, vouches for neither the re-aimed arc nor the planned
    one, so guidance stops thrusting (passage_unsafe, ERROR), the supervisor aborts outside the sphere and its
    avoidance burn carries the chaser clear."""
    d = _envelope_run_569()
    scenario = scenario_from_dict(d, name='envelope run 569')
    graph = HeadlessGraph(scenario)
    d['estimation']['torque_psd_n2m2s'] = 1e-6
    graph.guidance = GuidanceCore(GuidanceParams.from_scenario(
        scenario_from_dict(d, name='envelope run 569, torque noise 1e-6')))
    run = run_headless(scenario, graph)
    s = run.summary
    unsafe = [e for e in run.events if e['name'] == 'passage_unsafe']
    assert unsafe and unsafe[0]['level'] == 'ERROR', s['end_reason']
    assert s['outcome'] == 'ABORTED' and s['min_clearance_m'] > 10.0
    assert [b['kind'] for b in run.burns if b['t'] >= unsafe[0]['t']] == ['avoidance']
    assert not s['thrust_inside_restriction_sphere']


def test_the_planner_plans_from_the_target_filter_covariance_guidance_reads():
    """The headless loop hands the planner the estimate's covariance blocks as the planner node reads them from
    estimation/target/odom (the re-aim check starts from them, flyby.reaim.ReaimModel): at the plan time, the
    covariance the fly-by planner gets is covariance_from_published of the blocks guidance stored for that stamp."""
    import numpy as np

    from flyby_estimation.target_motion import covariance_from_published
    from flyby_planner.methods import FlybyMethod
    from flyby_planner.params import PlannerParams
    from flyby_planner.planner_core import PlannerCore

    class _PlanTime(BaseException):  # not an Exception: no core guard takes it for the core's fault
        pass

    class _StopAtPlan(FlybyMethod):
        def plan(self, core, t, q_hill_from_body, omega_body, why, covariance_body, reason):
            raise _PlanTime(t, q_hill_from_body, covariance_body)

    scenario = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    graph = HeadlessGraph(scenario)
    graph.planner = PlannerCore(PlannerParams.from_scenario(scenario))
    graph.planner.methods['flyby'] = _StopAtPlan()
    try:
        run_headless(scenario, graph)
        raise AssertionError('the run never planned')
    except _PlanTime as at:
        t, q_hill_from_body, covariance_body = at.args
    t_g, (q_g, _omega, blocks) = graph.guidance.targets.first_at_or_after(t)
    assert t_g == t and blocks is not None
    expected = covariance_from_published(q_g, *blocks)
    assert np.array_equal(q_hill_from_body, q_g) and np.array_equal(covariance_body, expected)
    sigma = np.sqrt(np.diag(covariance_body))
    assert np.all(sigma > 0.0) and np.all(sigma[:3] < np.radians(1.0))  # a converged filter's, not a bound


def test_a_core_exception_headless_is_the_graphs_node_error_and_the_mission_aborts():
    """The headless driver guards every core call as the node base does (flyby_msgs_py.core_guard): a planner that
    raises while it plans gives one node_error event, nothing more from the planner, and the supervisor's ABORTED."""
    from flyby_msgs_py import events
    from flyby_planner.methods import FlybyMethod

    class _Fails(FlybyMethod):
        def plan(self, core, t, *args, **kwargs):
            raise RuntimeError(f'injected planner fault at t = {t:.2f} s')

    scenario = load_scenario(SCENARIOS / 'paper_flyby.yaml')
    graph = HeadlessGraph(scenario)
    graph.planner.methods['flyby'] = _Fails()
    run = run_headless(scenario, graph)
    errors = [e for e in run.events if e['name'] == events.NODE_ERROR]
    assert len(errors) == 1 and errors[0]['values']['node'] == 'flyby_planner'
    assert errors[0]['values']['exception'] == 'RuntimeError' and 'injected planner fault' in errors[0]['message']
    assert [e for e in run.events if e['hardware_id'] == 'flyby_planner' and e['t'] > errors[0]['t']] == []
    assert run.summary['outcome'] == 'ABORTED' and run.summary['final_phase'] == 'ABORTED'
    assert run.burns == [] and run.summary['min_clearance_m'] > 0.0
