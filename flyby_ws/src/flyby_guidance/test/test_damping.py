"""post_capture: the rate-feedback damping law detumbles combined bodies of any inertia below seed 004's bound."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flyby_guidance.damping import (
    SEED004_MOMENTUM_BOUND_KG_M2_S,
    DampingGains,
    damping_command,
    pulse_modulated,
    simulate_damping,
)
from flyby_sim.dynamics.actuators import default_thruster_layout
from flyby_sim.dynamics.combined_body import inertia_from_principal
from flyby_sim.dynamics.rigid_body import ChaserAttitudeState, ReactionWheels
from flyby_sim.dynamics.rotation import quat_from_rotation_vector

_WHEELS = ReactionWheels.orthogonal(0.1, 4.0, 0.01)


_CHASER_INERTIA = np.diag([8.0, 10.0, 12.0])
_PERIOD_S = 1.0


@settings(max_examples=10)
@given(st.floats(0.0, 300.0), st.floats(0.05, 0.95), st.floats(0.05, 0.95),
       st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3), st.lists(st.floats(-0.1, 0.1), min_size=3, max_size=3))
def test_damping_converges_for_dispersed_inertias(scale, u, w, axes, omega0):
    """The chaser's inertia plus a target of any principal moments in the triangle inequality (scale * (1 - b))
    and any axes, any rate up to 0.1 rad/s per axis, gains from the chaser's inertia alone: below 0.1 kg m^2/s
    within the saturated couple's time plus ten of the slowest axis' time constants."""
    b = np.array([u, (1.0 - u) * w, (1.0 - u) * (1.0 - w)])
    inertia = _CHASER_INERTIA + inertia_from_principal(scale * (1.0 - b), quat_from_rotation_vector(np.array(axes)))
    state0 = ChaserAttitudeState(np.array([0.0, 0.0, 0.0, 1.0]), np.array(omega0), np.zeros(3))
    gains = DampingGains.for_inertia_bound(np.linalg.eigvalsh(_CHASER_INERTIA).min(), _PERIOD_S)
    h0 = float(np.linalg.norm(inertia @ state0.omega_body))
    time_constant = np.linalg.eigvalsh(inertia).max() / (gains.thruster_gain_n_m_s + gains.wheel_gain_n_m_s)
    duration = h0 / gains.max_thruster_torque_n_m + 10.0 * time_constant
    result = simulate_damping(inertia, _WHEELS, state0, gains, duration, period_s=_PERIOD_S)
    assert result.damped, (result.momentum_kg_m2_s[-1], h0)
    assert np.all(np.diff(result.momentum_kg_m2_s) <= 1e-12) or h0 < 0.1


def test_the_law_reads_no_inertia_and_moves_the_wheels_momentum_to_the_thrusters():
    gains = DampingGains()
    tau, u = damping_command(np.zeros(3), (0.5, 0.0, 0.0), gains, 0.1)
    # Equal and opposite on the body: thrusters -k_d h, the wheels' reaction -u = +k_d h.
    np.testing.assert_allclose(tau - u, 0.0, atol=1e-15)
    assert u[0] == pytest.approx(-gains.dump_rate_per_s * 0.5)


def test_paper_flyby_target_detumbled_with_the_chasers_thrusters_counts_fuel():
    """paper_flyby's target (1500 kg, diag(1200, 1000, 2000) kg m^2) with the chaser's inertia added, at 5 deg/s,
    the wheels holding some momentum: the couple allocated on the chaser's twelve thrusters brings the total
    (body and wheels) below 0.1 kg m^2/s."""
    inertia = np.diag([1200.0, 1000.0, 2000.0]) + _CHASER_INERTIA
    omega0 = math.radians(5.0) * np.array([0.0, 0.6, 0.8])
    state0 = ChaserAttitudeState(np.array([0.0, 0.0, 0.0, 1.0]), omega0, np.array([0.3, -0.2, 0.1]))
    layout = default_thruster_layout()
    # The gains from half the target's smallest moment (a bound a prior gives), the couple up to two pairs' 5 N m.
    gains = DampingGains.for_inertia_bound(500.0, 2.0, max_thruster_torque_n_m=4.0)
    result = simulate_damping(inertia, _WHEELS, state0, gains, 300.0, period_s=2.0, layout=layout)
    assert result.damped and result.momentum_kg_m2_s[-1] < SEED004_MOMENTUM_BOUND_KG_M2_S
    assert np.all(np.abs(result.state.h_wheels_n_m_s) < 0.1)
    # At least the momentum's worth of couple impulse through the 0.25 m arms of two thrusters.
    h0 = np.linalg.norm(inertia @ omega0 + state0.h_wheels_n_m_s)
    assert result.fuel_kg >= h0 / 0.25 / layout.exhaust_velocity_mps * 0.99


# -- guidance after the arm locks (PostCaptureControl) ----------------------------------------------------------

def test_inertia_upper_bound_bounds_every_combined_body():
    """lambda_max of the combined inertia (combined_body.combined_mass_properties) never exceeds the bound, for
    random bodies, axes and CoM offsets."""
    from flyby_guidance.damping import inertia_upper_bound
    from flyby_sim.dynamics.combined_body import combined_mass_properties

    rng = np.random.default_rng(16)
    for _ in range(200):
        moments = rng.uniform(1.0, 3000.0, 2)
        target = inertia_from_principal([moments[0], moments[1], rng.uniform(abs(moments[0] - moments[1]) + 1.0,
                                                                             moments.sum())],
                                        quat_from_rotation_vector(rng.normal(size=3)))
        x_s = rng.normal(size=3) * rng.uniform(0.1, 5.0)
        m, big_m = rng.uniform(10.0, 200.0), rng.uniform(1.0, 3000.0)
        props = combined_mass_properties(m, _CHASER_INERTIA, big_m, x_s, target)
        bound = inertia_upper_bound(_CHASER_INERTIA, target, m, big_m, float(np.linalg.norm(x_s)))
        assert np.linalg.eigvalsh(props.inertia_body_kg_m2).max() <= bound * (1.0 + 1e-12)


def _control(**changes):
    from flyby_guidance.damping import PostCaptureConfig, PostCaptureControl
    values = dict(momentum_threshold_kg_m2_s=SEED004_MOMENTUM_BOUND_KG_M2_S, settle_s=1.0, excitation='table1',
                  start_delay_s=2.0, window_s=25.0, damping=True, pulse_n_m_s=0.0)
    config = PostCaptureConfig(DampingGains.for_inertia_bound(500.0, 0.1), 0.1, **{**values, **changes})
    return PostCaptureControl(config, 0.1)


def test_damping_then_the_excitation_then_nothing():
    """The damping law until the momentum bound stays below half the threshold over settle_s (damping_complete with
    the excitation's start), then Table 1's firings as wrenches about the chaser CoM, each held over the control
    periods it covers (the one active at the middle of the period the command holds), the wheels idle."""
    from flyby_estimation.mass_properties_excitation import excitation_firings, firing_wrench
    from flyby_guidance.damping import MOMENTUM_MARGIN

    control = _control()
    h = np.zeros(3)
    cmd = control.command(100.0, (0.01, 0.0, 0.0), h, h, 3000.0)
    assert cmd.torque_body_n_m[0] < 0.0 and cmd.wheel_torque_body_n_m[0] > 0.0 and not cmd.events  # damping
    t = 100.0
    omega = 1e-5 * np.array([1.0, 0.0, 0.0])  # 3000 x 1e-5 = 0.03 < 0.05
    while True:
        t = round(t + 0.1, 6)
        cmd = control.command(t, omega, h, h, 3000.0)
        if cmd.events:
            break
    (level, name, _, values), = cmd.events
    assert name == 'damping_complete' and t == pytest.approx(101.1)  # the first window of settle_s without 100.0 s
    assert values['momentum_bound_kg_m2_s'] < MOMENTUM_MARGIN * SEED004_MOMENTUM_BOUND_KG_M2_S
    t_x = values['t_excitation_s']
    assert t_x == pytest.approx(103.1) and not np.any(cmd.torque_body_n_m)
    firings = excitation_firings('table1', t_x)
    events = []
    for k in range(1, 260):
        t_k = t + 0.1 * k
        cmd = control.command(t_k, omega, h, h, 3000.0)
        events += [e[1] for e in cmd.events]
        held_from = t_k + 0.1
        active = [f for f in firings if f.t_start_s <= held_from + 0.05 < f.t_start_s + f.duration_s]
        expected = firing_wrench(active[0]) if active else (np.zeros(3), np.zeros(3))
        np.testing.assert_allclose(cmd.force_body_n, expected[0], atol=1e-12)
        np.testing.assert_allclose(cmd.torque_body_n_m, expected[1], atol=1e-12)
        assert not np.any(cmd.wheel_torque_body_n_m)
    assert events == ['excitation_ended']  # once, at the last firing's end


def test_a_couple_below_a_pulse_is_carried_until_it_is_worth_one():
    """Pulse-frequency modulation of the damping's couple: a torque worth less than the pulse per period is not fired
    but carried, and fired whole once the carried angular impulse reaches the pulse, so the mean torque is kept (a
    couple below the thrusters' bit would never fire); a torque above it fires at once, as without the
    modulation."""
    carried, fired = np.zeros(3), []
    for _ in range(10):
        torque, carried = pulse_modulated(carried, (0.013, 0.0, 0.0), 0.1, 0.004)
        fired.append(torque[0])
    assert fired[:3] == [0.0, 0.0, 0.0] and fired[3] == pytest.approx(0.052)  # 4 x 0.0013 N m s >= 0.004
    assert sum(fired) * 0.1 + carried[0] == pytest.approx(10 * 0.013 * 0.1)
    torque, carried = pulse_modulated(np.zeros(3), (2.0, -1.0, 0.5), 0.1, 0.004)
    np.testing.assert_allclose(torque, (2.0, -1.0, 0.5)) and not np.any(carried)
