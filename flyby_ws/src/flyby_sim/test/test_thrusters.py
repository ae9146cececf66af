"""thrusters.py: validation, execution-error statistics, rocket equation, burn scheduling."""

import math

import numpy as np
import pytest

from flyby_sim.dynamics.constants import STANDARD_GRAVITY_M_S2
from flyby_sim.dynamics.propulsion import ManeuverRejected, ThrusterConfig, fuel_for_delta_v_kg
from flyby_sim.thrusters import ThrusterModel

SIGMA_MAG = 0.01
SIGMA_DIR = math.radians(0.5)
CONFIG = ThrusterConfig(max_thrust_n=10.0, isp_s=220.0, min_impulse_bit_ns=0.01,
                        max_delta_v_per_maneuver_mps=2.0, magnitude_error_sigma=SIGMA_MAG,
                        direction_error_sigma_rad=SIGMA_DIR)
EXACT = ThrusterConfig(max_thrust_n=10.0, isp_s=220.0, min_impulse_bit_ns=0.01,
                       max_delta_v_per_maneuver_mps=2.0, magnitude_error_sigma=0.0, direction_error_sigma_rad=0.0)


def model(config=CONFIG, seed=1):
    return ThrusterModel(config, np.random.default_rng(seed))


@pytest.mark.parametrize('dv, pattern', [
    ([math.nan, 0.0, 0.0], r'dv_hill \[nan, 0.0, 0.0\] has non-finite'),
    ([0.0, math.inf, 0.0], r'dv_hill \[0.0, inf, 0.0\] has non-finite'),
    ([2.0, 0.5, 0.0], r'\|dv_hill\| = 2.06155 m/s exceeds max_delta_v_per_maneuver_mps = 2 m/s'),
    ([5e-5, 0.0, 0.0], r'impulse m \|dv_hill\| = 0.005 N s .* below min_impulse_bit_ns = 0.01 N s'),
    ([0.0, 0.0, 0.0], r'impulse m \|dv_hill\| = 0 N s'),
    ([1.0, 0.0], r'3 components'),
])
def test_rejections_name_the_value(dv, pattern):
    with pytest.raises(ManeuverRejected, match=pattern) as info:
        model().schedule(10.0, dv, 0.0, 100.0)
    assert info.value.reason == str(info.value)


def test_rejected_commands_draw_no_random_numbers():
    a, b = model(seed=4), model(seed=4)
    with pytest.raises(ManeuverRejected):
        a.schedule(1.0, [9.0, 0.0, 0.0], 0.0, 100.0)
    assert a.schedule(1.0, [0.1, 0.0, 0.0], 0.0, 100.0) == b.schedule(1.0, [0.1, 0.0, 0.0], 0.0, 100.0)


def test_config_validation_names_the_field():
    with pytest.raises(ValueError, match='isp_s'):
        ThrusterConfig(10.0, 0.0, 0.01, 2.0, 0.0, 0.0)
    with pytest.raises(ValueError, match='direction_error_sigma_rad'):
        ThrusterConfig(10.0, 220.0, 0.01, 2.0, 0.01, -1.0)


def test_zero_sigmas_execute_the_command_exactly():
    burn = model(EXACT).schedule(10.0, [0.3, -0.4, 1.2], 0.0, 100.0)
    np.testing.assert_allclose(burn.dv_hill, [0.3, -0.4, 1.2], rtol=1e-15)


def test_error_statistics_match_the_sigmas():
    thrusters = model(seed=8)
    dv_cmd = np.array([0.3, -0.4, 1.2])
    u_cmd = dv_cmd / np.linalg.norm(dv_cmd)
    draws = np.array([thrusters.perturb(dv_cmd) for _ in range(20000)])
    magnitude_ratio = np.linalg.norm(draws, axis=1) / np.linalg.norm(dv_cmd) - 1.0
    u = draws / np.linalg.norm(draws, axis=1)[:, None]
    angle = np.arctan2(np.linalg.norm(np.cross(u, u_cmd), axis=1), u @ u_cmd)
    deviation = u - np.outer(u @ u_cmd, u_cmd)  # perpendicular part: uniform around the command
    print(f'magnitude std {magnitude_ratio.std():.5f} (sigma {SIGMA_MAG}), '
          f'rms angle {math.degrees(math.sqrt(np.mean(angle**2))):.4f} deg (sigma 0.5)')
    assert abs(magnitude_ratio.mean()) < 4 * SIGMA_MAG / math.sqrt(len(draws))
    assert magnitude_ratio.std() == pytest.approx(SIGMA_MAG, rel=0.03)
    # |angle| of a N(0, sigma) rotation: rms = sigma.
    assert math.sqrt(np.mean(angle**2)) == pytest.approx(SIGMA_DIR, rel=0.03)
    np.testing.assert_allclose(deviation.mean(axis=0), 0.0, atol=4 * SIGMA_DIR / math.sqrt(len(draws)))
    # Isotropic around the command: each of two perpendicular directions carries sigma^2 / 2.
    e1 = np.cross(u_cmd, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u_cmd, e1)
    for e in (e1, e2):
        assert math.sqrt(np.mean((deviation @ e) ** 2)) == pytest.approx(SIGMA_DIR / math.sqrt(2), rel=0.03)


def test_burn_duration_and_fuel_follow_the_rocket_equation():
    thrusters = model(EXACT)
    burn = thrusters.schedule(10.0, [1.0, 0.0, 0.0], 0.0, 100.0)
    ve = 220.0 * STANDARD_GRAVITY_M_S2
    assert burn.fuel_kg == pytest.approx(100.0 * (1.0 - math.exp(-1.0 / ve)), rel=1e-14)
    assert burn.fuel_kg == pytest.approx(100.0 * 1.0 / ve, rel=0.01)  # m dv / (Isp g0) within 1 %
    assert burn.end_s - burn.start_s == pytest.approx(burn.fuel_kg / (10.0 / ve), rel=1e-14)
    # Delivered delta-v ve ln(m0 / m1) equals the commanded one.
    assert ve * math.log(burn.mass_start_kg / burn.mass_end_kg) == pytest.approx(1.0, rel=1e-12)
    assert fuel_for_delta_v_kg(100.0, 0.0, ve) == 0.0


def test_overlapping_command_waits_and_is_late_and_late_command_starts_now():
    thrusters = model(EXACT)
    first = thrusters.schedule(10.0, [1.0, 0.0, 0.0], 0.0, 100.0)  # about 21.6 s long
    second = thrusters.schedule(15.0, [0.0, 0.5, 0.0], 0.0, 100.0)
    assert not first.late and first.start_s == 10.0
    assert second.late and second.start_s == first.end_s
    assert second.mass_start_kg == first.mass_end_kg
    late = model(EXACT).schedule(3.0, [0.1, 0.0, 0.0], 7.5, 100.0)
    assert late.late and late.start_s == 7.5


def test_earlier_stamped_command_goes_first_in_the_chain():
    thrusters = model(EXACT)
    later = thrusters.schedule(100.0, [0.5, 0.0, 0.0], 0.0, 100.0)
    earlier = thrusters.schedule(50.0, [0.5, 0.0, 0.0], 0.0, 100.0)
    assert earlier.start_s == 50.0 and not earlier.late
    assert thrusters.next_burn == earlier
    started = thrusters.start_next()
    assert started == earlier
    thrusters.finish_active()
    rescheduled = thrusters.start_next()
    assert rescheduled.start_s == later.start_s == 100.0
    assert rescheduled.mass_start_kg == earlier.mass_end_kg < later.mass_start_kg
