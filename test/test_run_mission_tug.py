"""After the capture in the graph (issue 16, DESIGN §10): the grasp, the damping of the combined body and the estimation
of the target's mass properties, real processes over Fast DDS, a ROS domain of the run's own, full speed, the bag read
back: flyby_testing.tug_short, flown once for the session (conftest.tug_short_run)."""

import numpy as np
import pytest

from flyby_mission.headless import run_headless
from flyby_mission.post_capture_figures import POST_CAPTURE_KEYS
from flyby_msgs_py import contract as c
from flyby_msgs_py.bag import read_bag
from flyby_msgs_py.convert import inertia_to_numpy
from flyby_sim.scenario import load_scenario
from flyby_testing import analyze_bag, read_summary

pytestmark = pytest.mark.slow

PHASES = [c.PHASE_ESTIMATION, c.PHASE_PLANNING, c.PHASE_TERMINAL_APPROACH, c.PHASE_TRAJECTORY_ADJUST, c.PHASE_FLYBY,
          c.PHASE_CAPTURE, c.PHASE_GRASP, c.PHASE_DAMPING, c.PHASE_MASS_ESTIMATION, c.PHASE_COMPLETE]


@pytest.fixture(scope='module')
def run(tug_short_run):
    return tug_short_run


def test_the_capture_goes_on_through_grasp_damping_and_mass_estimation_in_the_graph(run):
    out, scenario = run
    s = read_summary(out)
    assert s['outcome'] == 'CAPTURE' and s['phase_sequence'] == PHASES and s['final_phase'] == c.PHASE_COMPLETE
    sc = load_scenario(scenario)
    assert 0.0 < s['peak_grasp_force_n'] < sc.post_capture.grasp.max_force_n and not s['grasp_released']
    assert s['peak_grasp_torque_n_m'] < sc.post_capture.grasp.max_torque_n_m
    assert s['final_angular_momentum_kg_m2_s'] < 0.1  # seed 004 §3.2, from the truth
    assert not s['thrust_inside_restriction_sphere']  # the approach's; the combined body fires by design
    assert s['target_mass_error_pct'] < 2.0 and s['target_com_error_m'] < 0.05
    assert s['target_principal_moments_error_pct'] < 5.0 and s['target_principal_axes_error_deg'] < 1.0
    done = analyze_bag(out)
    assert done.returncode == 0 and 'every figure agrees' in done.stdout, done.stdout + done.stderr


FLOW_CONTROL_LAG_S = 3.0  # more than the 2 s the simulator's flow control lets a node lag (the launcher)


def test_the_graph_flies_what_the_headless_loop_flies_after_the_capture(run):
    """The same cores by the same rules: the simulator holds time for every command after the arm locks as before
    the capture, guidance and the estimator key the lock and the excitation on the events' stamps, so the figures
    after the capture are the same to the bit."""
    out, scenario = run
    graph, headless = read_summary(out), run_headless(load_scenario(scenario)).summary
    for key in ('t_grasp_s', 'phase_sequence', 'capture_position_error_m') + POST_CAPTURE_KEYS:
        assert graph[key] == headless[key], key
    # The whole run's fuel sums the graph's few more steps after COMPLETE (none fires): pairwise summation's rounding.
    assert graph['fuel_used_kg'] == pytest.approx(headless['fuel_used_kg'], rel=1e-12)
    topics = [c.absolute(t) for t in (c.MISSION_EVENTS, c.EST_TARGET_INERTIA, c.GUIDANCE_WRENCH)]
    bag = read_bag(out / 'bag', topics=topics)
    (done,) = [e['t'] for e in bag[topics[0]] if e['name'] == 'phase_changed' and e['values']['to'] == 'COMPLETE']
    names = [e['name'] for e in bag[topics[0]] if e['t'] <= done]  # the run's last step may take a late one
    assert 'waiting_for_command' not in names and 'late_command' not in names
    (locked,) = [e['t'] for e in bag[topics[0]] if e['name'] == 'grasp_damped']
    # A command every control period from the lock on. The last seconds before the launcher stops the graph are left
    # out: a node stopped while the recorder lags (the flow control allows 2 s) takes its last messages with it.
    wrench, t_until = bag[topics[2]], done - FLOW_CONTROL_LAG_S
    assert np.sum((wrench.t > locked) & (wrench.t <= t_until)) == pytest.approx(10.0 * (t_until - locked), abs=3)
    inertia = bag[topics[1]].messages
    assert inertia and inertia[-1].header.frame_id == c.FRAME_CHASER_BODY
    mass, com, _ = inertia_to_numpy(inertia[-1].inertia)
    assert mass == graph['target_mass_estimate_kg'] and com.tolist() == graph['target_com_estimate_m']
