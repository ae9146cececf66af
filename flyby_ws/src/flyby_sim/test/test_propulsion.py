"""flyby_sim.dynamics.propulsion: the burn chain the plant and the navigation filter share."""

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from flyby_sim.dynamics.propulsion import (
    BurnRequest,
    ManeuverRejected,
    ThrusterConfig,
    chain_burns,
    check_delta_v,
    delta_v_for_fuel_mps,
    fuel_for_delta_v_kg,
    insert_request,
)

CONFIG = ThrusterConfig(max_thrust_n=10.0, isp_s=220.0, min_impulse_bit_ns=0.01, max_delta_v_per_maneuver_mps=1.0,
                        magnitude_error_sigma=0.0, direction_error_sigma_rad=0.0)

REQUESTS = st.lists(st.tuples(st.floats(0.0, 100.0), st.floats(0.001, 0.5), st.sampled_from((-1.0, 1.0))),
                    min_size=1, max_size=6)


def _requests(specs):
    return [BurnRequest(t, seq, t, (dv * sign, 0.0, 0.0), (dv * sign, 0.0, 0.0))
            for seq, (t, dv, sign) in enumerate(specs)]


@given(REQUESTS, st.randoms(use_true_random=False))
def test_chain_is_the_same_whatever_the_arrival_order(specs, rng):
    """Burns in (requested start, command number) order, none overlapping, each delivering its delta-v
    by the rocket equation from the mass the burns before it left."""
    requests = _requests(specs)
    shuffled = list(requests)
    rng.shuffle(shuffled)
    in_order, arrived = [], []
    for r in requests:
        in_order = insert_request(in_order, r)
    for r in shuffled:
        arrived = insert_request(arrived, r)
    assert arrived == in_order
    burns = chain_burns(arrived, -math.inf, 100.0, CONFIG)
    for before, after in zip(burns, burns[1:], strict=False):
        assert after.start_s >= before.end_s and after.mass_start_kg == before.mass_end_kg
    for b in burns:
        assert b.start_s >= b.t_cmd_s and b.late == (b.start_s > b.t_cmd_s)
        assert delta_v_for_fuel_mps(b.mass_start_kg, b.fuel_kg, CONFIG.exhaust_velocity_mps) == pytest.approx(
            b.dv_mps, rel=1e-12)
        assert b.end_s - b.start_s == pytest.approx(b.fuel_kg / CONFIG.mass_flow_kg_s, rel=1e-12)


def test_rocket_equation_both_ways():
    fuel = fuel_for_delta_v_kg(100.0, 0.5, CONFIG.exhaust_velocity_mps)
    assert fuel == pytest.approx(100.0 * (1.0 - math.exp(-0.5 / (220.0 * 9.80665))), rel=1e-14)
    assert delta_v_for_fuel_mps(100.0, fuel, CONFIG.exhaust_velocity_mps) == pytest.approx(0.5, rel=1e-12)


def test_check_names_the_value():
    with pytest.raises(ManeuverRejected, match='exceeds max_delta_v_per_maneuver_mps'):
        check_delta_v((2.0, 0.0, 0.0), 100.0, CONFIG)
    with pytest.raises(ManeuverRejected, match='below min_impulse_bit_ns'):
        check_delta_v((1e-5, 0.0, 0.0), 100.0, CONFIG)
    with pytest.raises(ManeuverRejected, match='non-finite'):
        check_delta_v((math.nan, 0.0, 0.0), 100.0, CONFIG)
