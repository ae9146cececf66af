"""post_capture: the rate-feedback damping law detumbles combined bodies of any inertia below seed 004's bound."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flyby_guidance.post_capture import (
    SEED004_MOMENTUM_BOUND_KG_M2_S,
    DampingGains,
    damping_command,
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
