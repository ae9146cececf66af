"""The independent collision-avoidance monitor in the graph (docs/faults.md): with the planner and guidance left out,
a chaser coasting into the target is turned away by the monitor's CAM alone, judged from the truth in the bag."""

from flyby_testing import read_summary, run_mission, write_scenario


def _coast_into_the_target(data):
    data['chaser']['initial_position_hill_m'] = [12.0, 1.0, 0.5]
    data['chaser']['initial_velocity_hill_mps'] = [-0.3, 0.0, 0.0]  # contact near t = 35 s without a CAM
    data['simulation']['duration_s'] = 45.0


def test_the_cam_fires_with_the_planner_and_guidance_out_of_the_graph(tmp_path):
    scenario = write_scenario(tmp_path, base='paper_flyby_6dof', name='coast_in', edit=_coast_into_the_target)
    done = run_mission('--scenario', scenario, '--out', tmp_path / 'run', '--without', 'flyby_planner',
                       '--without', 'flyby_guidance')
    summary = read_summary(tmp_path / 'run')
    assert summary['cam_fired'] and 25.0 < summary['t_cam_s'] < 34.0, done.stdout[-2000:]
    assert summary['outcome'] == 'ABORTED' and summary['min_clearance_m'] > 0.1
