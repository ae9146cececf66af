"""Tracking of an optimal approach (flyby_guidance.tracking, GuidanceCore): the reference, the feed-forward over a
hold, the plume rule and the bound on every command, the re-plan request."""

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml

from flyby_guidance.guidance_core import GuidanceCore
from flyby_guidance.modes.interface import AttitudeCommandStamped
from flyby_guidance.params import GuidanceParams
from flyby_guidance.tracking import (
    ReferenceTrajectory,
    TrackingConfig,
    plume_rule,
    tracking_acceleration,
)
from flyby_msgs_py import contract as c
from flyby_msgs_py.wire import Event
from flyby_planner.optimal.problem import PLUME_MARGIN_M, planning_plume_radius_m
from flyby_sim.dynamics.rotation import quat_rotate
from flyby_sim.scenario import scenario_from_dict

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'
CONFIG = TrackingConfig(accel_max_mps2=0.138, plume_radius_m=5.0, frequency_rad_s=0.5, replan_error_m=0.5,
                        replan_cutoff_s=15.0)


def _cubic_reference(times):
    """r(t) = c0 + c1 t + c2 t^2 + c3 t^3 per axis: the Hermite interpolant is exact on it."""
    coef = np.array([[1.0, -2.0, 0.5], [0.3, 0.1, -0.2], [0.02, -0.01, 0.03], [-0.001, 0.002, 0.0005]])
    t = np.asarray(times, dtype=float)[:, None]
    r = coef[0] + coef[1] * t + coef[2] * t ** 2 + coef[3] * t ** 3
    v = coef[1] + 2 * coef[2] * t + 3 * coef[3] * t ** 2
    return r, v, coef


def test_reference_interpolates_a_cubic_exactly_and_holds_the_acceleration():
    times = np.array([0.0, 0.7, 1.2, 2.0, 3.5])
    r, v, coef = _cubic_reference(times)
    a = np.arange(15.0).reshape(5, 3)
    ref = ReferenceTrajectory(times, r, v, a)
    for t in (0.3, 1.0, 1.9, 3.1):
        r_t, v_t, a_t = ref.at(t)
        r_exact, v_exact, _ = _cubic_reference([t])
        assert r_t == pytest.approx(r_exact[0], abs=1e-12) and v_t == pytest.approx(v_exact[0], abs=1e-12)
        assert a_t == pytest.approx(a[np.searchsorted(times, t) - 1])
    assert ref.at(9.0)[2] == pytest.approx(np.zeros(3))  # after the end: nothing fed forward
    # the mean of the held acceleration over a hold that spans a point: weighted by the time on each side
    assert ref.mean_acceleration(0.6, 0.8) == pytest.approx(0.5 * a[0] + 0.5 * a[1])
    assert ref.mean_acceleration(3.4, 3.6) == pytest.approx(0.5 * a[3])  # half of it past the end


def test_plume_rule_removes_only_the_thrust_away_from_the_target_inside_the_radius():
    r = np.array((3.0, 0.0, 4.0))  # 5 m away: inside 5 m + the margin
    a = np.array((0.06, 0.02, 0.08))  # 0.1 m/s^2 straight away, plus a sideways part
    kept = plume_rule(a, r, 5.0)
    assert kept @ r == pytest.approx(0.0, abs=1e-15)
    assert kept == pytest.approx((0.0, 0.02, 0.0), abs=1e-15)
    assert plume_rule(-a, r, 5.0) == pytest.approx(-a)  # toward the target: unchanged
    far = r * (5.0 + PLUME_MARGIN_M + 0.01) / 5.0
    assert plume_rule(a, far, 5.0) == pytest.approx(a)


def test_plume_rule_applies_where_the_hold_carries_the_chaser_within_the_margin():
    """Outside the radius plus the margin now, but inside it by the hold's end: the rule applies, for the direction
    to the target now and at the hold's end; the planner keeps its plans' rule from twice the margin out, so a plan's
    braking there is flown."""
    r = np.array((5.0 + PLUME_MARGIN_M + 0.05, 0.0, 0.0))
    v = np.array((-0.5, 0.3, 0.0))  # 0.1 m inward over the 0.2 s of delay and hold
    a = np.array((0.1, 0.05, 0.0))  # away from the target, and sideways
    assert plume_rule(a, r, 5.0) == pytest.approx(a)  # by the position now alone: outside
    kept = plume_rule(a, r, 5.0, v, 0.2)
    end = r + 0.2 * v
    assert kept @ r <= 1e-15 and kept @ end <= 1e-15
    assert np.linalg.norm(kept) < np.linalg.norm(a)
    # passing by: the closest point of the hold's segment counts, not only its ends
    by = np.array((5.0 + PLUME_MARGIN_M - 0.02, 0.6, 0.0))  # both ends outside, the middle inside
    assert np.linalg.norm(by) > 5.0 + PLUME_MARGIN_M
    assert plume_rule(a, by, 5.0, (0.0, -6.0, 0.0), 0.2) @ by <= 1e-15
    assert plume_rule(a, by, 5.0, (1.0, 0.0, 0.0), 0.2) == pytest.approx(a)  # moving out: untouched
    assert planning_plume_radius_m(5.0) > 5.0 + PLUME_MARGIN_M
    assert plume_rule(a, (0.01, 0.0, 0.0), 0.0) == pytest.approx(a)  # radius zero: no rule


def test_every_command_keeps_the_bound_and_the_plume_rule():
    """Random estimates around a reference that brakes hard toward the target: the command never exceeds the bound
    and never has a component away from the target inside the plume radius."""
    rng = np.random.default_rng(14)
    times = np.linspace(0.0, 20.0, 41)
    r = np.outer(np.linspace(8.0, 3.0, 41), (1.0, 0.0, 0.0))
    ref = ReferenceTrajectory(times, r, np.tile((-0.25, 0.0, 0.0), (41, 1)), np.tile((0.12, 0.0, 0.0), (41, 1)))
    for _ in range(500):
        t = rng.uniform(0.0, 19.9)
        r_est = ref.at(t)[0] + rng.normal(0.0, 0.5, 3)
        a = tracking_acceleration(ref, t + 0.1, 0.1, t, r_est, ref.at(t)[1] + rng.normal(0.0, 0.2, 3), CONFIG)
        assert np.linalg.norm(a) <= CONFIG.accel_max_mps2 * (1 + 1e-12)
        if np.linalg.norm(r_est) < CONFIG.plume_radius_m:
            assert a @ r_est <= 1e-12
    assert tracking_acceleration(ref, 25.0, 0.1, 24.9, r[-1], np.zeros(3), CONFIG) == pytest.approx(np.zeros(3))


def _guidance():
    d = copy.deepcopy(yaml.safe_load((SCENARIOS / 'jacobsen_optimal.yaml').read_text()))
    sc = scenario_from_dict(d)
    core = GuidanceCore(GuidanceParams.from_scenario(sc))
    core.on_phase(c.PHASE_OPTIMAL_APPROACH)
    times = np.linspace(100.0, 160.0, 301)
    r = np.outer(np.linspace(50.0, 3.0, 301), (1.0, 0.0, 0.0))
    v = np.tile((-47.0 / 60.0, 0.0, 0.0), (301, 1))
    core.on_trajectory(times, r, v, np.zeros((301, 3)))
    return sc, core, r, v


def test_guidance_sends_the_tracking_force_in_body_axes_with_the_attitude_command():
    sc, core, r, v = _guidance()
    q = np.array((0.0, 0.0, 1.0, 0.0))  # body +x along hill -x, at the target
    (cmd,) = core.on_chaser_estimate(100.0, r[0] + (0.1, 0.0, 0.0), v[0], q, np.zeros(3))
    assert isinstance(cmd, AttitudeCommandStamped) and cmd.t == pytest.approx(100.1)
    # 10 cm behind the reference along +x: the feedback pushes toward -x hill, i.e. +x body
    force_hill = quat_rotate(q, np.array(cmd.force_body_n))
    assert force_hill[0] == pytest.approx(-sc.chaser.mass_kg * 0.25 * 0.1, rel=1e-6)


def test_guidance_asks_once_for_a_re_plan_when_the_tracking_error_grows():
    _, core, r, v = _guidance()
    q = np.array((0.0, 0.0, 1.0, 0.0))
    out = core.on_chaser_estimate(110.0, r[50] + (0.0, 0.6, 0.0), v[50], q, np.zeros(3))
    (asked,) = [o for o in out if isinstance(o, Event)]
    assert asked.name == 'replan_requested' and asked.values['tracking_error_m'] == pytest.approx(0.6, abs=1e-6)
    out = core.on_chaser_estimate(110.1, r[50] + (0.0, 0.7, 0.0), v[50], q, np.zeros(3))
    assert not [o for o in out if isinstance(o, Event)]
    # a new trajectory may be asked for again; none in the last replan_cutoff_s before the grasp
    core.on_trajectory(np.linspace(110.0, 160.0, 11), np.zeros((11, 3)), np.zeros((11, 3)), np.zeros((11, 3)))
    out = core.on_chaser_estimate(150.0, (0.0, 2.0, 0.0), np.zeros(3), q, np.zeros(3))
    assert not [o for o in out if isinstance(o, Event)]
