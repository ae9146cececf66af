"""The report library (flyby_mission.report) and scripts/mission_report.py on real runs: one cut short before any
plan, one that captures, one short run of the six-degree-of-freedom chaser through run_mission --report, one short
synchronized approach (seed 001 Fig 4-7), one short capture that goes on through the grasp, the damping and the
mass-property estimation (seed 004 Fig 5)."""

import math
import subprocess
import sys

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation
from test_run_mission_sync import _short as sync_short

from flyby_mission.report import analysis, loading, post_capture, post_capture_analysis, sync, sync_analysis
from flyby_mission.report.writer import write_report
from flyby_msgs_py import contract as c
from flyby_sim.scenario import load_scenario
from flyby_testing import ROOT, read_summary, run_mission, with_duration, write_scenario

SCRIPT = ROOT / 'scripts' / 'mission_report.py'
ALL_FIGURES = ('trajectory_xz.png', 'trajectory_3d.png', 'range.png', 'maneuvers.png', 'estimation.png',
               'clearance.png')
RIGID_BODY_FIGURES = ('attitude.png', 'pointing.png', 'wheels.png', 'thrusters.png')
PNG_MAGIC = b'\x89PNG\r\n\x1a\n'


def check_pngs(paths, largest=400_000):
    for path in paths:
        data = path.read_bytes()
        assert data.startswith(PNG_MAGIC), path
        assert 10_000 < len(data) < largest, (path, len(data))


def test_match_stamps_pairs_the_same_instants_only():
    truth = np.arange(0.0, 2.0, 0.05)  # 20 Hz steps
    estimate = np.array([0.1 + 1e-9, 0.2, 0.25 + 1e-3, 1.95, 3.0])  # 10 Hz-ish, one off-grid, one beyond
    i_est, i_truth = loading.match_stamps(estimate, truth)
    assert i_est.tolist() == [0, 1, 3]
    assert np.allclose(truth[i_truth], [0.1, 0.2, 1.95])


@pytest.mark.slow
def test_report_of_a_run_cut_before_any_plan(tmp_path, capsys):
    """40 s: the estimator runs, the planner has not planned yet (it waits 60 s of observation), so
    there is no path, grasp or burn. What can be drawn is, the rest is said on stderr."""
    run_dir = tmp_path / 'run'
    result = run_mission('--scenario', write_scenario(tmp_path, edit=with_duration(40.0)), '--out', run_dir,
                         '--in-process')
    assert result.returncode == 3, result.stderr
    assert read_summary(run_dir)['outcome'] == 'TIME_LIMIT'

    written = write_report(run_dir, tmp_path / 'report')

    assert [p.name for p in written] == [n for n in ALL_FIGURES if n != 'maneuvers.png']
    assert all(p.parent == tmp_path / 'report' for p in written)
    check_pngs(written)
    err = capsys.readouterr().err
    assert 'maneuvers.png skipped: no executed burn' in err
    assert '/planner/path' in err and '/planner/grasp' in err
    assert 'failed' not in err


@pytest.mark.slow
def test_report_of_a_captured_run_from_the_command_line(tmp_path):
    """A complete fly-by kept short (60 s estimate -> 30 s, shorter transfer and fly-by): every figure."""
    def quick_capture(data):
        data['planner'].update(min_observation_s=30.0, transfer_min_s=100.0, transfer_max_s=160.0,
                               flyby_duration_s=150.0)
    run_dir = tmp_path / 'run'
    result = run_mission('--scenario', write_scenario(tmp_path, edit=quick_capture), '--out', run_dir,
                         '--in-process')
    assert result.returncode == 0, result.stderr
    assert read_summary(run_dir)['outcome'] == 'CAPTURE'

    cli = subprocess.run([sys.executable, str(SCRIPT), str(run_dir)], capture_output=True, text=True,
                         timeout=120, cwd=ROOT)

    assert cli.returncode == 0, cli.stderr
    written = [run_dir / name for name in ALL_FIGURES]  # --out defaults to the run directory
    assert cli.stdout.split() == [str(p) for p in written]
    check_pngs(written)
    assert 'skipped' not in cli.stderr and 'failed' not in cli.stderr


def test_sphere_intervals_interpolate_entry_and_exit():
    t = np.arange(0.0, 10.0, 1.0)
    r = np.array([20.0, 16.0, 14.0, 12.0, 14.0, 17.0, 15.0, 13.0, 12.0, 11.0])  # in at 1.5 s, out 4.5, in 6
    intervals = loading.sphere_intervals(t, np.column_stack((r, np.zeros(10), np.zeros(10))), 15.0)
    assert np.allclose(intervals, [(1.5, 4 + 1 / 3), (6.0, 9.0)])  # the last one open at the end
    assert loading.sphere_intervals(t, np.full((10, 3), 20.0), 15.0) == []


def test_continuous_quaternions_undo_sign_flips():
    angle = np.linspace(0.0, 3.0 * np.pi, 50)  # more than a turn about z: w changes sign
    q = np.column_stack((np.zeros(50), np.zeros(50), np.sin(angle / 2), np.cos(angle / 2)))
    flipped = q * np.where(np.arange(50) % 3 == 0, -1.0, 1.0)[:, None]
    assert np.allclose(analysis.continuous_quaternions(flipped), q)


@pytest.mark.slow
def test_report_of_a_rigid_body_run_from_run_mission(tmp_path):
    """paper_flyby_6dof cut at 40 s after 20 s of observation: the transfer burn (about 30 s) fires thrusters and
    opens the pointing window. run_mission --report writes the rigid-body figures besides the others, and the
    velocities the figures draw are in hill: the truth's range rate is the range's derivative."""
    def short(data):
        data['simulation']['duration_s'] = 40.0
        data['planner']['min_observation_s'] = 20.0
    run_dir = tmp_path / 'run'
    result = run_mission('--scenario', write_scenario(tmp_path, base='paper_flyby_6dof', edit=short), '--out',
                         run_dir, '--in-process', '--report')
    assert result.returncode == 3, result.stderr
    summary = read_summary(run_dir)
    assert summary['outcome'] == 'TIME_LIMIT' and summary['maneuvers_executed'] >= 1
    assert summary['pointing_error_p95_deg'] is not None

    written = [run_dir / name for name in ALL_FIGURES + RIGID_BODY_FIGURES]
    assert [f'report: {p}' for p in written] == [line for line in result.stderr.splitlines()
                                                  if line.startswith('report: ')]
    check_pngs(written)
    assert 'failed' not in result.stderr and 'skipped' not in result.stderr

    run = loading.Run(run_dir)
    assert run.rigid_body and run.sphere == []  # 50 m out: never inside the restriction sphere
    truth = run.need(c.SIM_CHASER_ODOM)
    r, r_dot = analysis.range_and_rate(truth)
    coasting = np.abs(truth.t - run.burns[0].t_start) > 3.0  # the burn lasts about 1.5 s
    assert np.max(np.abs(np.gradient(r, truth.t) - r_dot)[coasting][1:-1]) < 1e-6  # [m/s]
    read_in_body_axes = truth._replace(orientation_xyzw=np.tile((0.0, 0.0, 0.0, 1.0), (len(r), 1)))
    assert np.max(np.abs(analysis.range_and_rate(read_in_body_axes)[1] - r_dot)) > 1e-3  # what the check catches


def test_euler_angles_are_the_scenarios_and_their_derivative_is_right():
    """euler_rpy inverts the scenario's reading of rpy_rad, R = Rz(psi) Ry(theta) Rx(phi); euler_from_hill_rotation is
    how a small rotation about hill axes (the estimator's attitude error) moves them, as a finite difference shows."""
    rng = np.random.default_rng(15)
    q = Rotation.random(50, random_state=rng)
    rpy = sync_analysis.euler_rpy(q.as_quat())
    phi, theta, psi = rpy.T
    one, zero = np.ones(50), np.zeros(50)
    rx = np.stack((np.stack((one, zero, zero), -1), np.stack((zero, np.cos(phi), -np.sin(phi)), -1),
                   np.stack((zero, np.sin(phi), np.cos(phi)), -1)), axis=1)
    ry = np.stack((np.stack((np.cos(theta), zero, np.sin(theta)), -1), np.stack((zero, one, zero), -1),
                   np.stack((-np.sin(theta), zero, np.cos(theta)), -1)), axis=1)
    rz = np.stack((np.stack((np.cos(psi), -np.sin(psi), zero), -1), np.stack((np.sin(psi), np.cos(psi), zero), -1),
                   np.stack((zero, zero, one), -1)), axis=1)
    assert np.allclose(rz @ ry @ rx, q.as_matrix(), atol=1e-12)
    dtheta_hill = 1e-7 * rng.standard_normal((50, 3))
    moved = sync_analysis.euler_rpy((Rotation.from_rotvec(dtheta_hill) * q).as_quat())
    step = (moved - rpy + np.pi) % (2.0 * np.pi) - np.pi
    predicted = np.einsum('nij,nj->ni', sync_analysis.euler_from_hill_rotation(rpy), dtheta_hill)
    assert np.allclose(step, predicted, rtol=1e-4, atol=1e-13)


@pytest.mark.slow
def test_report_of_a_synchronized_approach_draws_seed_001_fig_4_to_7(tmp_path):
    """The short synchronized approach of test_run_mission_sync flown by run_mission --report (every node in one
    process, to be quick): the report adds seed 001's Fig 4-7, and what they draw agrees with the truth computed here
    another way: the kinetic energies at a sample of stage 4 from the raw twist and wheel speeds and the scenario's
    Table 1 masses and inertias, the target's constant (torque-free) at Table 1's initial rate's; in stages 3-4 the
    chaser keeps its attitude in target_body as summary.json measures it and turns with the target, which it did not do
    in stage 1, and its position in target_body holds while orbiting."""
    scenario_path = write_scenario(tmp_path, base='seweryn_tumbling', name='sync_short', edit=sync_short)
    out = tmp_path / 'run'
    result = run_mission('--scenario', scenario_path, '--out', out, '--in-process', '--report')
    assert result.returncode == 0, result.stderr
    summary = read_summary(out)
    assert summary['outcome'] == 'CAPTURE' and summary['method'] == 'sync'

    no_burn = tuple(n for n in ALL_FIGURES if n != 'maneuvers.png')  # the synchronized approach fires no impulse
    written = [out / name for name in no_burn + RIGID_BODY_FIGURES + tuple(n for n, _ in sync.FIGURES)]
    assert [f'report: {p}' for p in written] == [line for line in result.stderr.splitlines()
                                                  if line.startswith('report: ')]
    assert 'failed' not in result.stderr
    check_pngs(written[-4:], largest=700_000)
    run = loading.Run(out)
    windows = sync_analysis.stage_windows(run.phases)
    (t1, t2), (t3, t4) = windows['stages 1-2'], windows['stages 3-4']
    assert t2 == t3 and t4 == summary['t_grasp_s']

    attitude = sync_analysis.sync_attitude(run)
    assert attitude.t_stage3 == pytest.approx(t3, abs=0.05)
    synced = (attitude.t >= attitude.t_stage3) & (attitude.t <= t4)
    drift_deg = np.degrees(attitude.drift_rad[synced])
    assert drift_deg.max() == pytest.approx(summary['relative_attitude_drift_max_deg'], abs=1e-9)
    assert drift_deg.max() < 0.5
    relative_rate_deg_s = np.degrees(np.linalg.norm(attitude.omega_relative_body, axis=1))
    assert relative_rate_deg_s[synced].max() < 0.5
    assert np.median(relative_rate_deg_s[(attitude.t >= t1) & (attitude.t < t1 + 10.0)]) > 10.0  # 21.4 deg/s tumble

    translation = sync_analysis.sync_translation(run)
    orbiting = [(a, b) for phase, a, b in run.phases if phase == c.PHASE_ORBITING][0]
    held = translation.r_target_body[(translation.t >= orbiting[0]) & (translation.t <= orbiting[1])]
    assert np.ptp(held, axis=0).max() < 0.05  # [m] seed 001 Fig 2: constant in the target's frame

    data = yaml.safe_load(scenario_path.read_text())
    energy = sync_analysis.kinetic_energies(run)
    chaser, wheels = run.need(c.SIM_CHASER_ODOM, c.SIM_CHASER_WHEELS)
    k = int(np.searchsorted(chaser.t, 0.5 * (t3 + t4)))
    (i,) = np.flatnonzero(energy.t == chaser.t[k])
    (j,) = np.flatnonzero(wheels.t == chaser.t[k])
    speed_mps = np.linalg.norm(chaser.linear[k])  # in chaser_body axes: turning it into hill keeps its norm
    omega = chaser.angular[k]
    assert energy.chaser_translational[i] == pytest.approx(0.5 * data['chaser']['mass_kg'] * speed_mps ** 2, rel=1e-12)
    assert energy.chaser_rotational[i] == pytest.approx(0.5 * omega @ np.array(data['chaser']['inertia_kg_m2']) @ omega,
                                                         rel=1e-12)
    assert np.allclose(data['chaser']['wheels']['axes'], np.eye(3))  # each wheel spins at its speed + omega's part
    spin = wheels.velocity[j] + omega
    assert energy.chaser_wheels[i] == pytest.approx(0.5 * data['chaser']['wheels']['spin_inertia_kg_m2'] * spin @ spin,
                                                     rel=1e-12)
    omega0 = np.array(data['target']['initial_rate']['omega_body_rad_s'])
    table_1 = 0.5 * omega0 @ np.array(data['target']['inertia_kg_m2']) @ omega0  # 478.85 J
    assert np.allclose(energy.target_rotational, table_1, rtol=1e-9)
    assert np.all(energy.target_translational == 0.0)  # the hill origin is its centre of mass


@pytest.mark.slow
def test_report_after_the_capture_draws_seed_004_fig_5_the_grasp_and_the_damping(tmp_path, tug_short_run):
    """The short paper_flyby_tug of the post-capture tests (conftest.tug_short_run, flown once), the four post-capture
    figures drawn from its bag (write_report adds them for a post_capture scenario). What they plot: the truth mass and
    moments are the scenario's; the estimates' final values and errors are summary.json's to the bit (the same truth
    by the same functions); the target's CoM in chaser_body holds while welded; the principal axes' error dphi and the
    per-axis angle agree; the message's inertia has the event's principal moments; the combined CoM's velocity changes
    by the thrusters' net impulse over the total mass; the grasp's peak force and the momentum at the end of the
    damping are summary.json's, within the arm's limit and below seed 004's 0.1 kg m^2/s."""
    out, scenario_path = tug_short_run
    summary = read_summary(out)
    assert summary['outcome'] == 'CAPTURE' and summary['final_phase'] == c.PHASE_COMPLETE
    scenario = load_scenario(scenario_path)

    run = loading.Run(out)
    assert run.post_capture
    written = []
    for name, draw in post_capture.FIGURES:
        draw(run, tmp_path / name)
        written.append(tmp_path / name)
    check_pngs(written, largest=700_000)

    d = post_capture_analysis.mass_property_estimates(run)
    assert d.true_mass_kg == scenario.target.mass_kg == 1500.0
    assert d.true_moments_kg_m2.tolist() == pytest.approx([1000.0, 1200.0, 2000.0], rel=1e-12)
    assert len(d.t) >= 20 and np.all(d.mass_sigma_kg > 0.0) and np.all(d.com_sigma_m > 0.0)
    assert d.mass_kg[-1] == summary['target_mass_estimate_kg']
    assert np.linalg.norm(d.com_body_m[-1] - d.true_com_at_estimate_m[-1]) == summary['target_com_error_m']
    assert 100.0 * np.max(np.abs(d.moments_kg_m2[-1] / d.true_moments_kg_m2 - 1.0)) == \
        summary['target_principal_moments_error_pct']
    assert math.degrees(np.max(d.axes_angle_rad[-1])) == summary['target_principal_axes_error_deg']
    assert np.ptp(d.true_com_body_m, axis=0).max() < 1e-9  # [m] one rigid body
    # Axis 1 turns by the rotation about axes 2 and 3 (small angles).
    assert np.hypot(*d.axes_error_rad[-1, 1:]) == pytest.approx(d.axes_angle_rad[-1, 0], rel=1e-3)
    assert np.linalg.eigvalsh(d.inertia_body_kg_m2[-1]) == pytest.approx(np.sort(d.moments_kg_m2[-1]), rel=1e-9)

    m = post_capture_analysis.combined_motion(run)
    thrust = run.need(c.SIM_CHASER_THRUST)
    steps = (thrust.t[1:] > m.t[0] + 1e-9) & (thrust.t[1:] <= m.t[-1] + 1e-9)  # each step's mean force [N], hill
    impulse = np.sum(thrust.force[1:][steps] * np.diff(thrust.t)[steps, None], axis=0)
    total_kg = scenario.target.mass_kg + scenario.chaser.mass_kg - summary['fuel_used_kg']
    assert np.linalg.norm(impulse / total_kg) > 5e-3  # [m/s] the excitation moves it
    # Left out here: hill's turn (n t ~ 0.03 rad of ~15 mm/s) and the gravity gradient (3 n^2 r t), ~0.5 mm/s.
    assert np.linalg.norm(m.v_com_inertial[-1] - m.v_com_inertial[0] - impulse / total_kg) < 1.5e-3
    assert np.all(np.abs(m.attitude_error_hill) <= m.attitude_sigma3_hill)

    t, force, torque, _ = post_capture_analysis.grasp_contact(run)
    assert t[0] == pytest.approx(summary['t_grasp_s'], abs=0.1)
    assert force.max() == summary['peak_grasp_force_n'] < scenario.post_capture.grasp.max_force_n
    assert torque.max() == summary['peak_grasp_torque_n_m'] < scenario.post_capture.grasp.max_torque_n_m

    t, momentum = post_capture_analysis.damping_momentum(run)
    assert momentum[0] > 100.0  # [kg m^2/s] the target's 2000 kg m^2 at 5 deg/s, 175, and the chaser's orbit about it
    assert momentum[-1] == summary['final_angular_momentum_kg_m2_s'] < 0.1
    assert t[-1] - t[0] == pytest.approx(summary['damping_time_s'], abs=0.05)
