"""TransportNavigation: the combined CoM's navigation in TRANSPORT takes the accelerometer only where it
sees a thrust; coasting, the velocity comes from the relative positions and the modelled gravity (CW)."""

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest

from flyby_estimation.combined_com_filter import CombinedComFilter
from flyby_estimation.params import TransportNavigationParams
from flyby_estimation.transport_navigation import TransportNavigation, command_error
from flyby_sim.dynamics.orbital import nonlinear_relative_accel_components, rk4_step_floats
from flyby_sim.dynamics.rotation import quat_from_rotation_vector, quat_to_matrix
from flyby_sim.scenario import load_scenario
from flyby_testing import SCENARIOS

SCENARIO = load_scenario(SCENARIOS / 'matsunaga_orbit_advance.yaml')
PARAMS = TransportNavigationParams.from_scenario(SCENARIO)
COM = np.array([0.2, 0.0, 0.0])  # the combined CoM from the chaser's, chaser_body axes
NAV_MASS_KG = 50.0
COM_SIGMA_M = 0.002  # its prior's 1-sigma per axis


def _fly(pulse_at_s=None, dv_mps=4e-4, duration_s=300.0, seed=3, seen=True, commanded=False, command_mps=None,
         accel_error_mps=0.0):
    """The body fixed in hill, from rest on V-bar 1 km ahead (a CW equilibrium; the scenario's nonlinear relative
    motion leaves it at 2e-7 m/s^2), 10 Hz samples with the scenario's sensor noise; optionally a one-sample pulse
    along hill x (commanded as command_mps, dv_mps where None; its accelerometer sample off by accel_error_mps more).
    Returns (t, v_estimate, v_truth) of the CoM (the body fixed in hill: the chaser's CoM moves as the combined
    one)."""
    rng = np.random.default_rng(seed)
    n = SCENARIO.mean_motion_rad_s
    nav = TransportNavigation(PARAMS, 0.0, COM, COM_SIGMA_M**2 * np.eye(3), NAV_MASS_KG)
    sigma_r = SCENARIO.sensors.relative_position.noise_sigma_m
    sigma_a = SCENARIO.sensors.chaser_imu.accel_noise_sigma_mps2
    omega = np.array([0.0, -n, 0.0])  # fixed in hill: its inertial rate
    estimate = SimpleNamespace(q_hill_from_body=np.array([0.0, 0.0, 0.0, 1.0]), omega_body=omega,
                               attitude_covariance_hill=1e-8 * np.eye(3))
    x = np.array([1000.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    out = []
    for k in range(1, int(duration_s / 0.1) + 1):
        t = 100.0 + 0.1 * k
        x = np.array(rk4_step_floats(lambda _t, y: [*y[3:], *nonlinear_relative_accel_components(
            y[:3], y[3:], n, SCENARIO.orbit_radius_m)], t - 0.1, x.tolist(), 0.1))
        accel = np.cross(omega, np.cross(omega, -COM)) + sigma_a * rng.standard_normal(3)
        if pulse_at_s is not None and abs(t - pulse_at_s) < 0.05:
            x[3] += dv_mps
            accel[0] += (dv_mps + accel_error_mps) / 0.1 if seen else 0.0
            if commanded:  # guidance's command for the interval that ends at this sample
                nav.on_command(t - 0.1, np.array([NAV_MASS_KG * (dv_mps if command_mps is None else command_mps) / 0.1,
                                                  0.0, 0.0]))
        nav.on_position(t, x[:3] - COM + sigma_r * rng.standard_normal(3))
        navigated, _ = nav.on_imu(t, estimate, accel)
        if navigated is not None:
            out.append((t, navigated[1], x[3:].copy()))  # fixed in hill, the chaser's CoM moves as the combined
    return out


def test_coasting_the_velocity_comes_from_the_positions_not_the_accelerometers_noise():
    """0.2 mm/s is seed 004 §3.2's third condition on 50 kg: integrating the accelerometer's noise (1e-4 m/s^2 at
    10 Hz) walks the velocity by about that much; without it the estimate is within a few hundredths of a mm/s."""
    flown = _fly()
    errors = np.array([np.linalg.norm(v - truth) for t, v, truth in flown if t > 250.0])
    assert np.sqrt(np.mean(errors ** 2)) < 5e-5 and errors.max() < 1e-4


def test_a_thrust_is_taken_from_the_accelerometer_at_once():
    """A pulse of 0.4 mm/s (one firing thruster's minimum impulse bit on 50 kg would be 0.2 mm/s, 20 sigma of the
    accelerometer over one sample) is in the estimate at the sample, not after the positions show it."""
    flown = _fly(pulse_at_s=250.0)
    before = [v for t, v, _ in flown if t < 249.95][-1]
    after = next(v for t, v, _ in flown if t > 249.95)  # the pulse's own sample
    assert abs((after - before)[0] - 4e-4) < 3e-5
    errors = np.array([np.linalg.norm(v - truth) for t, v, truth in flown if t > 300.0])
    assert errors.max() < 1e-4


def test_a_firing_the_accelerometer_does_not_see_is_taken_from_guidances_command():
    """A small firing below the accelerometer's gate (a terminal firing on paper_flyby_transport's 1600 kg: one thruster
    at its bit is 0.6 sigma) is a known input, guidance's command for that interval: in the estimate at the sample;
    without the command only the positions show it, over tens of seconds."""
    jumps = {}
    for commanded in (True, False):
        flown = _fly(pulse_at_s=250.0, seen=False, commanded=commanded)
        before = [v for t, v, _ in flown if t < 249.95][-1]
        after = next(v for t, v, _ in flown if t > 249.95)
        jumps[commanded] = (after - before)[0]
    assert abs(jumps[True] - 4e-4) < 3e-5 and abs(jumps[False]) < 1e-4


def test_a_firing_both_see_is_their_least_variance_fusion_and_one_the_command_does_not_explain_the_accelerometers():
    """A commanded pulse of 0.1 mm/s the accelerometer sees (10 sigma over one sample, 10 times its command's 3 %
    error: a terminal firing on a heavy body), its sample 4 sigma off: the estimate jumps by the command's delta-v, not
    the accelerometer's (which alone took 40 um/s of error, and the noise spikes of its gate 60 mN s each on 1149
    kg, 20 of the navigation's sigmas; transport_envelope draw 1). A pulse ten times its command (a thrust the command
    does not explain) is the accelerometer's."""
    sigma_dv = SCENARIO.sensors.chaser_imu.accel_noise_sigma_mps2 * 0.1

    def jump(**kwargs):
        flown = _fly(pulse_at_s=250.0, commanded=True, **kwargs)
        before = [v for t, v, _ in flown if t < 249.95][-1]
        return (next(v for t, v, _ in flown if t > 249.95) - before)[0]

    assert abs(jump(dv_mps=1e-4, accel_error_mps=4.0 * sigma_dv) - 1e-4) < 0.25 * sigma_dv
    assert abs(jump(dv_mps=1e-3, command_mps=1e-4) - 1e-3) < 3.0 * sigma_dv


def _coast(duration_s, seed=5, p_true=(-2.9, 0.01, 0.02), prior_error_m=(0.005, -0.003, 0.004), firings=()):
    """A CombinedComFilter over a body held at rest inertially (it turns in hill at n about the orbit normal) on the
    scenario's nonlinear relative motion near V-bar 100 m ahead, 10 Hz positions of the chaser's CoM with 1 cm of
    noise; the prior of p off by prior_error_m with a 5 mm sigma; at each of firings (t [s], dv [m/s, hill], its
    1-sigma [m/s]) a known input, the truth off it by a draw of that sigma. Returns (p_estimate, its covariance,
    v_estimate, its covariance, v_truth, p)."""
    rng = np.random.default_rng(seed)
    n, radius_m = SCENARIO.mean_motion_rad_s, SCENARIO.orbit_radius_m
    p_true = np.asarray(p_true)
    x = [100.0, 0.3, 0.5, 2e-4, -1e-4, 1e-4]
    c0 = quat_to_matrix(quat_from_rotation_vector(np.array([0.2, 1.0, -0.4])))

    def rhs(_t, y):
        return [*y[3:], *nonlinear_relative_accel_components(y[:3], y[3:], n, radius_m)]

    def c_hill_from_body(t):  # d/dt C = -Omega^H x C with the body at rest inertially, Omega^H = [0, -n, 0]
        return quat_to_matrix(quat_from_rotation_vector(np.array([0.0, n * t, 0.0]))) @ c0

    nav = CombinedComFilter(PARAMS.nav.config(initial_velocity_sigma_mps=0.05, gate_probability=0.9999),
                            p_true + np.asarray(prior_error_m), (0.005 ** 2) * np.eye(3))
    pending = sorted(firings, key=lambda f: f[0])
    for k in range(int(round(duration_s / 0.1)) + 1):
        t = 0.1 * k
        if k:
            x = rk4_step_floats(rhs, t - 0.1, x, 0.1)
            nav.propagate_to(t)
        while pending and pending[0][0] <= t + 1e-9:
            _, dv, sigma = pending.pop(0)
            x[3:] = (np.array(x[3:]) + np.asarray(dv) + sigma * rng.standard_normal(3)).tolist()
            nav.add_thrust(t, t, dv, sigma**2 * np.eye(3))
        c = c_hill_from_body(t)
        y = np.array(x[:3]) + c @ p_true + 0.01 * rng.standard_normal(3)
        if k:
            nav.update(t, y, c)
        else:
            nav.initialize(t, y, c)
    _, v, covariance = nav.state()
    return nav.p, nav.p_covariance_m2, v, covariance[3:, 3:], np.array(x[3:]), p_true


def test_a_body_turning_at_the_orbit_rate_fixes_the_combined_com():
    """Over half an orbit the circle C p traces in hill is no CW coast: the 1 cm positions fix the combined CoM to a
    fraction of a millimetre (paper_flyby_transport's mass-property estimate leaves 3-9 mm, each mm 0.0017 N s of
    velocity error on its 1600 kg), and the CoM's velocity with it; over 100 s the prior stays."""
    p, p_cov, v, _, v_truth, p_true = _coast(3000.0)
    sigma = np.sqrt(np.diag(p_cov))
    assert np.all(sigma < 5e-4)
    assert np.all(np.abs(p - p_true) < 3.0 * sigma)
    assert 1600.0 * np.linalg.norm(v - v_truth) < 0.002
    p, p_cov, _, _, _, p_true = _coast(100.0)
    assert np.all(np.sqrt(np.diag(p_cov)) > 0.8 * 0.005)
    assert np.linalg.norm(p - p_true) > 0.5 * np.linalg.norm((0.005, -0.003, 0.004))


def test_across_firings_the_filter_keeps_what_it_knows_of_the_combined_com():
    """Firings every 200 s (terminal firings of a few bits on a heavy body: 20 um/s, known to 3 %) do not reset what
    the positions told of p: over half an orbit it is fixed as without them (a coast of 200 s alone leaves the prior's
    5 mm), and the velocity's sigma covers its error."""
    firings = [(200.0 * k, (2e-5 * (-1) ** k, 1e-5, 0.0), 0.03 * 2.2e-5) for k in range(1, 15)]
    p, p_cov, v, v_cov, v_truth, p_true = _coast(3000.0, firings=firings)
    sigma = np.sqrt(np.diag(p_cov))
    assert np.all(sigma < 1e-3)
    assert np.all(np.abs(p - p_true) < 3.0 * sigma)
    assert (v - v_truth) @ np.linalg.solve(v_cov, v - v_truth) < 16.3  # chi2(3) at 0.999


def _filter():
    return CombinedComFilter(PARAMS.nav.config(initial_velocity_sigma_mps=0.05, gate_probability=0.9999),
                             -COM, COM_SIGMA_M**2 * np.eye(3))


def test_a_consider_update_moves_the_state_and_leaves_the_combined_com_and_what_is_known_of_it():
    """estimate_p False (Schmidt): the position moves to the measurement as far as its covariance says, p and its
    covariance stay, and the cross-covariance keeps p's uncertainty in the state's."""
    nav = _filter()
    nav.initialize(0.0, np.array([100.0, 0.0, 0.0]) - COM, np.eye(3))
    p_before, p_cov_before = nav.p.copy(), nav.p_covariance_m2
    assert nav.update(0.1, np.array([100.02, 0.0, 0.0]) - COM, np.eye(3), estimate_p=False).kind == 'accepted'
    assert np.array_equal(nav.p, p_before) and np.allclose(nav.p_covariance_m2, p_cov_before, rtol=0, atol=1e-18)
    r, _, covariance = nav.state()
    assert 100.0 < r[0] < 100.02 and np.all(np.diag(covariance)[:3] > COM_SIGMA_M**2)
    nav.update(0.2, np.array([100.02, 0.0, 0.0]) - COM, np.eye(3))
    assert not np.array_equal(nav.p, p_before)  # estimated again


def test_an_outlier_is_rejected_and_a_lost_filter_restarts_from_the_position_keeping_the_combined_com():
    """One position 1 m off is an outlier (the state stays); a run of them that agree (the body truly elsewhere)
    restarts the position from the measurement, with p and its covariance kept."""
    nav = _filter()
    y = np.array([100.0, 0.0, 0.0]) - COM
    nav.initialize(0.0, y, np.eye(3))
    for k in range(1, 50):
        nav.update(0.1 * k, y, np.eye(3))
    r_before = nav.state()[0]
    assert nav.update(5.0, y + np.array([1.0, 0.0, 0.0]), np.eye(3)).kind == 'outlier'
    assert np.allclose(nav.state()[0], r_before, atol=1e-6)
    p_before, p_cov_before = nav.p.copy(), nav.p_covariance_m2
    kinds = []
    while 'reset' not in kinds and len(kinds) < 30:
        kinds.append(nav.update(5.0 + 0.1 * (len(kinds) + 1), y + np.array([1.0, 0.0, 0.0]), np.eye(3)).kind)
    assert kinds[-1] == 'reset' and set(kinds[:-1]) == {'outlier'}
    assert np.array_equal(nav.p, p_before) and np.allclose(nav.p_covariance_m2, p_cov_before, rtol=0, atol=1e-18)
    assert abs(nav.state()[0][0] - (r_before[0] + 1.0)) < 0.03


def test_a_slewing_body_does_not_teach_the_combined_com():
    """A body turning at 0.02 rad/s (a slew, HELD_RATE_ORBITS times the orbit's rate and more) leaves the combined CoM
    as it was given; held, it is learnt."""
    given = {}
    for rate in (0.02, 0.0):
        nav = TransportNavigation(PARAMS, 100.0, COM, COM_SIGMA_M**2 * np.eye(3), NAV_MASS_KG)
        rng = np.random.default_rng(3)
        for k in range(1, 1501):
            t = round(100.0 + 0.1 * k, 6)
            q = quat_from_rotation_vector(np.array([0.0, 0.0, rate * (t - 100.0)]))
            estimate = SimpleNamespace(q_hill_from_body=q, omega_body=np.array([0.0, 0.0, rate]),
                                       attitude_covariance_hill=1e-8 * np.eye(3))
            nav.on_position(t, np.array([1000.0, 0.0, 0.0]) - quat_to_matrix(q) @ (COM + 0.003)
                            + 0.01 * rng.standard_normal(3))
            nav.on_imu(t, estimate, None)
        given[rate] = nav.filter.p.copy()
    assert np.array_equal(given[0.02], -COM)
    assert not np.array_equal(given[0.0], -COM)


def test_the_combined_com_is_given_on_its_grid_with_the_time_since_the_last_firing():
    """Guidance waits at every stamp of COM_PERIOD_S's grid after the final estimate for the combined CoM, so every one
    has it, with the time since the last firing; a couple (no force) is a firing: its thrusters' errors push."""
    n = SCENARIO.mean_motion_rad_s
    nav = TransportNavigation(PARAMS, 100.0, COM, COM_SIGMA_M**2 * np.eye(3), NAV_MASS_KG)
    estimate = SimpleNamespace(q_hill_from_body=np.array([0.0, 0.0, 0.0, 1.0]), omega_body=np.array([0.0, -n, 0.0]),
                               attitude_covariance_hill=1e-8 * np.eye(3))
    rng = np.random.default_rng(7)
    given = {}
    for k in range(1, 6001):
        t = round(100.0 + 0.1 * k, 6)
        if abs(t - 420.0) < 1e-6:
            nav.on_command(t - 0.1, np.zeros(3), np.array([0.0, 0.0, 0.5]))
        nav.on_position(t, np.array([1000.0, 0.0, 0.0]) - COM + 0.01 * rng.standard_normal(3))
        _, refined = nav.on_imu(t, estimate, np.zeros(3))
        if refined is not None:
            given[t] = refined[2]
    assert sorted(given) == [150.0 + 50.0 * j for j in range(12)]
    assert [given[t] for t in (150.0, 400.0)] == pytest.approx([50.0, 300.0])
    assert [given[t] for t in (450.0, 700.0)] == pytest.approx([30.0, 280.0])  # from the sample ending its interval


def test_command_error_is_the_thrusters_magnitude_and_direction_errors_at_least_the_floor():
    floor = TransportNavigation.COMMAND_ERROR_FLOOR
    assert command_error(0.0, 0.0) == floor
    assert command_error(0.01, math.radians(1.0)) == floor  # 0.02 in all: the floor
    assert command_error(0.05, math.radians(2.0)) == pytest.approx(math.sqrt(0.05 ** 2 + math.radians(2.0) ** 2),
                                                                   rel=1e-15)
    assert command_error(0.0, 0.04) == pytest.approx(0.04, rel=1e-15)
    assert command_error(0.04, 0.0) == pytest.approx(0.04, rel=1e-15)


def _commanded_velocity_covariance(params, dv_mps=2e-3):
    """The velocity covariance [m^2/s^2] of a navigation on params (the body fixed in hill 1 km ahead on V-bar,
    noiseless positions and accelerometer) right after a firing of dv_mps along hill x that the accelerometer does
    not see, commanded by guidance, at a sample with no position (nothing updates it after the command)."""
    n = SCENARIO.mean_motion_rad_s
    nav = TransportNavigation(params, 0.0, COM, COM_SIGMA_M**2 * np.eye(3), NAV_MASS_KG)
    omega = np.array([0.0, -n, 0.0])
    estimate = SimpleNamespace(q_hill_from_body=np.array([0.0, 0.0, 0.0, 1.0]), omega_body=omega,
                               attitude_covariance_hill=1e-8 * np.eye(3))
    centripetal = np.cross(omega, np.cross(omega, -COM))  # the rotation term alone: no acceleration of the CoM
    for k in range(1, 51):
        t = round(100.0 + 0.1 * k, 6)
        nav.on_position(t, np.array([1000.0, 0.0, 0.0]) - COM)
        nav.on_imu(t, estimate, centripetal)
    nav.on_command(t, np.array([NAV_MASS_KG * dv_mps / 0.1, 0.0, 0.0]))
    navigated, _ = nav.on_imu(round(t + 0.1, 6), estimate, centripetal)
    return navigated[2][3:, 3:]


def test_the_navigation_takes_its_command_error_from_its_params():
    """The command error is command_error of the params' thrusters' errors (matsunaga_orbit_advance's are nil: the
    floor), and an unseen commanded firing's delta-v dv adds (error |dv|)^2 to the velocity's variance per axis."""
    nav = TransportNavigation(PARAMS, 0.0, COM, COM_SIGMA_M**2 * np.eye(3), NAV_MASS_KG)
    assert nav.command_error == command_error(PARAMS.thrust_magnitude_sigma, PARAMS.thrust_misalignment_sigma_rad)
    worse = dataclasses.replace(PARAMS, thrust_magnitude_sigma=0.08, thrust_misalignment_sigma_rad=math.radians(3.0))
    error = math.hypot(0.08, math.radians(3.0))
    nav = TransportNavigation(worse, 0.0, COM, COM_SIGMA_M**2 * np.eye(3), NAV_MASS_KG)
    assert nav.command_error == pytest.approx(error, rel=1e-15)
    dv_mps = 2e-3
    added = _commanded_velocity_covariance(worse, dv_mps) - _commanded_velocity_covariance(PARAMS, dv_mps)
    np.testing.assert_allclose(added, (error ** 2 - TransportNavigation.COMMAND_ERROR_FLOOR ** 2) * dv_mps ** 2
                               * np.eye(3), rtol=1e-6, atol=1e-18)
