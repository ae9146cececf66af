"""The abort's avoidance burn coasts through guidance's burns still to fly (flyby_mission.abort_escape): a burn is
sent ahead of its start and the plant flies it whatever follows, so an abort judged without it calls a coast safe that
the burn then turns at the target."""

import copy
from pathlib import Path

import numpy as np

from flyby_mission.abort_escape import PendingBurns, coast_through
from flyby_mission.headless import HeadlessGraph, run_headless
from flyby_msgs_py import events, wiring
from flyby_sim.dynamics.orbital import cw_coast
from flyby_sim.scenario import load_scenario, scenario_from_dict

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'
N_RAD_S = 0.0011


def test_coast_through_adds_each_burn_in_the_window_at_its_start():
    r, v = np.array([10.0, 50.0, 0.0]), np.array([0.01, 0.0, 0.0])
    burns = [(5.0, np.array([0.0, -0.1, 0.0])), (8.0, np.array([0.02, 0.0, 0.01])), (30.0, np.ones(3))]
    at_8 = cw_coast(*np.split(cw_coast(r, v, 5.0, N_RAD_S) + np.r_[0, 0, 0, 0, -0.1, 0], 2), 3.0, N_RAD_S)
    expected = cw_coast(at_8[:3], at_8[3:] + [0.02, 0.0, 0.01], 12.0, N_RAD_S)
    np.testing.assert_allclose(coast_through(r, v, 0.0, 20.0, burns, N_RAD_S), expected, rtol=0, atol=1e-12)
    # A burn at or before the estimate's stamp is in the estimate; none: the plain coast.
    np.testing.assert_allclose(coast_through(r, v, 5.0, 7.0, burns[:1], N_RAD_S), cw_coast(r, v, 2.0, N_RAD_S))


def test_pending_burns_drop_the_ones_the_estimate_holds():
    pending = PendingBurns()
    pending.add(12.0, [0.0, 1.0, 0.0])
    pending.add(8.0, [1.0, 0.0, 0.0])
    assert [b[0] for b in pending.after(5.0)] == [8.0, 12.0]
    assert [b[0] for b in pending.after(10.0)] == [12.0]
    assert pending.after(12.0) == [] and pending.burns == []


def test_guidance_raising_after_sending_the_injection_the_abort_burns_after_it():
    """paper_flyby, guidance's core raising at its first chaser estimate from 509 s: the 513 s injection was sent at
    508 s and flies. Judged without it the coast was 'passively safe (51.76 m)' and the injection then carried the
    chaser 0.27 m from the target (the CAM monitor fired at 807.5 s); now the abort's burn follows the injection and
    the truth's coast after the run stays clear of the target."""
    d = copy.deepcopy(load_scenario(SCENARIOS / 'paper_flyby.yaml').to_dict())
    scenario = scenario_from_dict(d, name='paper_flyby')
    graph = HeadlessGraph(scenario)
    nominal = graph.guidance.on_chaser_estimate

    def on_chaser_estimate(t, *args, **kwargs):
        if t >= 509.0:
            raise ZeroDivisionError(f'injected guidance fault at t = {t:.2f} s')
        return nominal(t, *args, **kwargs)

    graph.guidance.on_chaser_estimate = on_chaser_estimate
    run = run_headless(scenario, graph)
    (error,) = [e for e in run.events if e['name'] == events.NODE_ERROR]
    assert error['values']['node'] == wiring.GUIDANCE
    (verdict,) = [e for e in run.events if e['name'] in (events.AVOIDANCE_BURN, events.NO_AVOIDANCE_BURN)]
    assert "through guidance's burns still to fly (1)" in verdict['message']
    assert [b['t'] for b in run.burns if b['t'] > 509.0] == [513.012014398]
    assert run.summary['outcome'] == 'ABORTED'
    # The verdict is the truth's: the injection carries the chaser back past the target (its fly-by arc, passively
    # safe by the planner's margin), where the coast without it stayed 51.76 m off.
    r_end, v_end = np.asarray(graph.truth.r[-1]), np.asarray(graph.truth.v[-1])  # point mass: hill axes
    n = scenario.mean_motion_rad_s
    least_m = min(np.linalg.norm(cw_coast(r_end, v_end, dt, n)[:3]) for dt in np.arange(0.0, 1500.0, 0.5))
    assert float(verdict['values']['clearance_m']) < 1.0 and least_m < 5.0
