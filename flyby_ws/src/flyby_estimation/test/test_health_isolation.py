"""The thrust monitor's isolation by a hypothesis per thruster (flyby_estimation.thrust_isolation, docs/faults.md):
on constructed residual series, a thruster off inside a couple or a trim is its own deficit, not its partners'
leak; a leak while a couple fires is the leak; where leak and deficit explain the series alike, or the commands
are unknown, the thrusters are named by direction as before; nominal noise names nothing."""

import functools
import math

import numpy as np
import pytest

from flyby_estimation import health
from flyby_estimation.health import ThrustMonitor
from flyby_estimation.thrust_book import BIT_THRUSTERS
from flyby_estimation.thrust_isolation import Allocator, BurnShare, Commanded, isolate
from flyby_sim.dynamics.actuators import allocate_wrench, default_thruster_layout, plan_burn
from flyby_sim.dynamics.rotation import quat_from_axis_angle, quat_rotate

LAYOUT = default_thruster_layout(10.0, 220.0, 0.01)  # scenarios/paper_flyby_6dof.yaml's thrusters
SIGMA_A = 1e-4  # its accelerometer [m/s^2]
MASS = 100.0
DT = 0.1
RELATIVE = 3.0 * math.hypot(0.01, math.radians(0.5))  # its thrusters' specified errors, 3 sigma
LEVER_MIN = 0.25  # the default layout's least moment arm [m]
TRIM = BurnShare(5, (-0.5776480541903488, 0.4841530481243293, 0.657205106098564), 10.0 * 0.0022862686585 / MASS,
                 10.0, MASS, 10.0 / MASS, 0.0022862686585)  # faults_single run 411's trim, at 727.953 s


@functools.cache
def _wrench_thrusts(torque):
    """The plant's thrusts [N] of a pure torque [N m] (``allocate_wrench``)."""
    return allocate_wrench(LAYOUT, np.zeros(3), torque).thrusts_n


TRIM_THRUSTS = plan_burn(LAYOUT, TRIM.direction_body, TRIM.dv_mps, MASS, TRIM.thrust_n).allocation.thrusts_n


def _monitor(layout=LAYOUT):
    return ThrustMonitor(SIGMA_A, RELATIVE, LAYOUT.force_directions_body, layout)


def _fly(monitor, commands, thrust_of, seed, burns_at=(), directions=LAYOUT.force_directions_body):
    """Feed ``monitor`` one 10 Hz interval per command (torque [N m] of guidance's wrench, chaser_body; the
    interval indices in ``burns_at`` carry the TRIM burn), the accelerometer measuring ``thrust_of(k, nominal)``
    (each thruster's thrust [N] given its nominal allocation) along the thrusters' true ``directions`` plus its
    noise, as the book reports it; the detections."""
    rng = np.random.default_rng(seed)
    d = np.asarray(directions)
    share = TRIM.overlap_s / DT
    found = []
    for k, torque in enumerate(commands):
        burn = k in burns_at
        # the interval's mean thrust [N] of each thruster: the wrench, plus the trim over its share
        nominal = _wrench_thrusts(torque) + (share * TRIM_THRUSTS if burn else 0.0)
        measured = d.T @ thrust_of(k, nominal) / MASS + SIGMA_A * rng.standard_normal(3)
        expected_n = math.hypot(*torque) / LEVER_MIN + (share * TRIM.thrust_n if burn else 0.0)
        net = LAYOUT.force_directions_body.T @ (share * TRIM_THRUSTS) / MASS if burn else np.zeros(3)
        granularity = BIT_THRUSTERS * LAYOUT.min_impulse_bit_n_s / DT if any(torque) else 0.0
        edges = ((TRIM.seq, TRIM.accel_mps2, True, True),) if burn else ()
        monitor.on_interval(measured - net, expected_n / MASS, np.zeros(3), granularity / MASS, edges,
                            Commanded(DT, MASS, (0.0, 0.0, 0.0), torque, (TRIM,) if burn else ()))
        found += monitor.judge(DT * (k + 1))[0]
    return found


def _off(index, k_from=0):
    """Thruster ``index`` off from interval k_from on."""
    def thrust_of(k, nominal):
        out = nominal.copy()
        if k >= k_from:
            out[index] = 0.0
        return out
    return thrust_of


COUPLE = (0.0, 0.5, 0.0)  # thrusters 9 and 10 at 1 N each: a pure torque about body y
IDLE = (0.0, 0.0, 0.0)


@pytest.mark.parametrize('seed', range(5))
def test_a_thruster_off_in_a_couple_is_its_own_deficit_not_its_partners_leak(seed):
    """The couple fires six intervals and stops; thruster 9 gives nothing: its partner 10's newton along -z, only
    while the couple fires, which no leak (present commanded or not) explains. Named thruster 9's deficit alone
    (by direction: the thrusters against the residual, 8 and 9)."""
    assert np.flatnonzero(allocate_wrench(LAYOUT, np.zeros(3), COUPLE).thrusts_n).tolist() == [9, 10]
    (found,) = _fly(_monitor(), [COUPLE] * 6 + [IDLE] * 10, _off(9), seed)
    assert (found.kind, found.values['candidates'], found.values['isolation']) == ('thrust_deficit', [9],
                                                                                   'hypothesis')
    (by_direction,) = _fly(_monitor(layout=None), [COUPLE] * 6 + [IDLE] * 10, _off(9), seed)
    assert (by_direction.kind, by_direction.values['candidates']) == ('thrust_deficit', [8, 9])


def test_a_thruster_off_in_a_trim_of_opposing_pairs_is_a_deficit_not_its_partners_leak():
    """faults_single run 411: a 2.3 ms trim re-allocated so every thruster gives its minimum impulse bit fires all
    twelve, thruster 9 at 7.66 N; with it off, the trim's -z thrusters (10, 11) push unbalanced. The trim lacks
    0.018 N s, about the window's bound, so it is seen on some draws of the noise (run 411's at 1.1 x its bound);
    each time it is, named the deficit of the trim's +z thrusters 8 and 9 (commanded alike, the accelerometer cannot
    tell them apart), where the direction rule named their partners' leak on some (``thrust_excess`` on [10, 11]: in
    run 411 two healthy thrusters closed)."""
    named, by_direction = [], []
    for seed in range(30):
        named += _fly(_monitor(), [IDLE] * 20, _off(9), seed, burns_at=(4,))
        by_direction += _fly(_monitor(layout=None), [IDLE] * 20, _off(9), seed, burns_at=(4,))
    assert len(named) >= 10
    assert {(f.kind, tuple(f.values['candidates']), f.values['isolation']) for f in named} == {
        ('thrust_deficit', (8, 9), 'hypothesis')}
    assert ('thrust_excess', [10, 11]) in [(f.kind, f.values['candidates']) for f in by_direction]


@pytest.mark.parametrize('seed', range(5))
def test_a_leak_while_the_couple_fires_is_named_the_leak(seed):
    """Thruster 10 stuck on at 2 N while the couple commands it 1 N: the plant gives the larger, so the residual is
    1 N along -z while the couple fires and 2 N after; no deficit (present only commanded) nor thruster 11's leak
    (the same whether or not 10 is commanded) explains both. Named thruster 10's leak alone."""
    def stuck(_k, nominal):
        out = nominal.copy()
        out[10] = max(out[10], 2.0)
        return out

    (found,) = _fly(_monitor(), [COUPLE] * 6 + [IDLE] * 10, stuck, seed)
    assert (found.kind, found.values['candidates'], found.values['isolation']) == ('thrust_excess', [10],
                                                                                   'hypothesis')


@pytest.mark.parametrize('seed', range(3))
def test_where_leak_and_deficit_explain_the_series_alike_the_thrusters_are_named_by_direction(seed):
    """The couple firing through the whole window with thruster 9 off: its partner's leak from before the window
    predicts the same series, so no hypothesis is chosen and the direction rule names them, as it did before (a
    leak named a deficit would go unanswered where a thruster stuck on is catastrophic). Without the commands
    (a monitor with no layout) it names by direction too."""
    (found,) = _fly(_monitor(), [COUPLE] * 16, _off(9), seed)
    assert (found.kind, found.values['candidates'], found.values['isolation']) == ('thrust_deficit', [8, 9],
                                                                                   'direction')


@pytest.mark.parametrize('seed', range(10))
def test_nominal_noise_names_nothing(seed):
    """The accelerometer's noise and the thrusters' specified errors on a pulsing couple and a trim: the monitor
    detects nothing, and the hypotheses asked of such a window name no thruster (a fault of no size explains it,
    leak and deficit alike)."""
    rng = np.random.default_rng(seed)
    gains = 1.0 + 0.01 * rng.standard_normal(LAYOUT.count)
    commands = [COUPLE if (k // 3) % 2 else IDLE for k in range(200)]
    assert _fly(_monitor(), commands, lambda _k, nominal: nominal * gains, seed, burns_at=(50, 120)) == []
    allocator = Allocator(LAYOUT)
    firings = [allocator.firing(Commanded(DT, MASS, (0.0, 0.0, 0.0), c, ())) for c in commands[:10]]
    residuals = SIGMA_A * rng.standard_normal((10, 3))
    assert isolate(residuals, firings, [SIGMA_A**2] * 10, LAYOUT.force_directions_body,
                   LAYOUT.max_thrust_n / MASS, RELATIVE / 3.0) is None


@pytest.mark.parametrize('seed', range(5))
def test_a_leak_from_its_onset_is_named_at_the_stuck_rule_s_detection(seed):
    """Thruster 7 stuck on at 1 N from the middle of a quiet window (the onset hypothesis: nothing before it, a
    share in its interval, all of it after), its force 1.5 deg off its nominal direction (a 3-sigma draw of the
    specified misalignment: faults_single run 34's leak was 2 deg off and failed the test without its own error in
    the variance): named thruster 7's leak, with its parallel twin 6 (the same direction, neither commanded: the
    accelerometer cannot tell them apart)."""
    def stuck(k, nominal):
        out = nominal.copy()
        if k >= 12:
            out[7] = max(out[7], 1.0)
        return out

    turned = LAYOUT.force_directions_body.copy()
    turned[7] = quat_rotate(quat_from_axis_angle((1.0, 0.0, 0.0), math.radians(1.5)), turned[7])
    found = _fly(_monitor(), [IDLE] * 30, stuck, seed, directions=turned)
    assert [(f.kind, f.values['candidates'], f.values['isolation']) for f in found] == [
        ('thrust_excess', [6, 7], 'hypothesis')]
    assert found[0].t <= DT * (12 + health.LEAK_INTERVALS + 1) + 1e-9


def test_after_a_thrust_detection_the_next_is_named_by_direction():
    """The hypotheses allocate over every thruster; a detection's answer may close thrusters (``thrusters_isolated``,
    which the estimator does not hear), after which the plant allocates over the others: the run's later thrust
    detections are named by direction (faults_single run 103: thruster 3 stuck on, [2, 3] closed, a later burn's
    shortfall on them fitted thrusters 0 and 1's leak, two healthy thrusters more closed)."""
    commands = [COUPLE] * 6 + [IDLE] * 40 + [COUPLE] * 6 + [IDLE] * 10
    found = [f for f in _fly(_monitor(), commands, _off(9), 0) if f.detected]
    assert [(f.kind, f.values['candidates'], f.values['isolation']) for f in found] == [
        ('thrust_deficit', [9], 'hypothesis'), ('thrust_deficit', [8, 9], 'direction')]
