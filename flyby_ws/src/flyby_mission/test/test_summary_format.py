"""The terminal summary by the kind of run (flyby_mission.summary.format_summary, fleet_summary.format_fleet_summary):
the figures that apply and no row of '-': a capture, a run that starts attached (with and without a transport) and
two chasers, from real headless runs' summaries."""

from pathlib import Path

import pytest

from flyby_mission.fleet_summary import combine, format_fleet_summary
from flyby_mission.headless import run_headless
from flyby_mission.post_capture_figures import TRANSPORT_KEYS
from flyby_mission.summary import format_summary
from flyby_sim.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[4] / 'scenarios'


def rows(text):
    """{label: text} of a printed summary, each row checked to have a value that is not '-'."""
    table = {}
    for line in text.splitlines():
        label, _, value = line.strip().partition('  ')
        table[label] = value.strip()
    assert all(v and v != '-' and ' - /' not in v and '/ -' not in v for k, v in table.items()
               if not k.startswith('chaser')), text
    return table


@pytest.fixture(scope='module')
def capture():
    return run_headless(load_scenario(SCENARIOS / 'paper_flyby.yaml')).summary


@pytest.fixture(scope='module')
def attached():
    return run_headless(load_scenario(SCENARIOS / 'matsunaga_tugrobot.yaml')).summary


def test_a_capture_prints_its_capture_figures_and_nothing_that_does_not_apply(capture):
    table = rows(format_summary(capture))
    for label in ('scenario', 'outcome', 'seed', 'method', 'grasp time', 'capture position error',
                  'capture velocity error', 'delta-v total', 'fuel used', 'min clearance', 'sim time', 'wall time'):
        assert label in table, label
    assert table['capture position error'] == f"{capture['capture_position_error_m']:.4g} m"
    # A point-mass fly-by: no pointing, no thrusting approach's figures, nothing after the capture.
    for label in ('pointing error p95 / max', 'approach time', 'thrust away in plume', 'start', 'damping',
                  'transport goal', 'faults injected', 'nodes killed'):
        assert label not in table, label


def test_a_run_that_starts_attached_says_so_instead_of_capture_figures(attached):
    assert attached['t_grasp_s'] is None and attached['capture_position_error_m'] is None
    table = rows(format_summary(attached))
    assert table['start'].startswith('attached: the chaser holds the target from t = 0')
    for label in ('method', 'grasp time', 'capture position error', 'capture velocity error', 'delta-v total',
                  'min clearance', 'thrust inside sphere', 'pointing error p95 / max', 'peak grasp force / torque',
                  'damping', 'late maneuvers', 'transport goal'):
        assert label not in table, label
    for label in ('fuel used', 'target mass error', 'target CoM error', 'target moments / axes error'):
        assert label in table, label


def test_a_transport_prints_its_conditions_and_its_goal(attached):
    """Transport figures as transport_figures writes them (matsunaga_orbit_advance's, 34 s headless, not flown here)."""
    moved = dict(attached, phase_sequence=['MASS_ESTIMATION', 'TRANSPORT', 'COMPLETE'],
                 transport_goal_hill_m=[1000.0, 0.0, 0.0], transport_final_position_error_m=0.8812,
                 transport_orbital_momentum_error_n_m_s=0.00329, transport_final_angular_momentum_kg_m2_s=0.0042,
                 transport_wheel_momentum_n_m_s=0.61, transport_wheel_momentum_share=0.1525,
                 transport_conditions_met=True, transport_fuel_kg=0.0697, transport_impulses=33,
                 transport_time_s=1200.0, transport_settle_time_s=140.0, transport_settle_bound_s=300.0,
                 transport_replans=1, transport_terminal_firings=4)
    assert set(TRANSPORT_KEYS) <= set(moved)
    table = rows(format_summary(moved))
    assert table['transport goal'] == '[1000, 0, 0] m in hill'
    assert table['transport conditions'] == 'met'
    assert table['final position error'] == '0.8812 m'
    assert table['final momentum error'] == '0.00329 N s'
    assert table['body angular momentum'] == '0.0042 kg m^2/s'
    assert table['wheel momentum'] == '0.61 N m s (fullest wheel at 15.2 % of capacity)'
    assert table['settle time'] == '140 s (bound 300 s)'
    assert table['transport time / fuel'] == '1200 s / 0.0697 kg'
    assert table['impulses / re-plans / terminal firings'] == '33 / 1 / 4'
    unbounded = rows(format_summary(dict(moved, transport_settle_bound_s=None)))
    assert unbounded['settle time'] == '140 s'
    assert 'start' in table and 'grasp time' not in table
    missed = rows(format_summary(dict(moved, transport_conditions_met=False)))
    assert missed['transport conditions'] == 'missed'
    unflown = rows(format_summary(dict(moved, **dict.fromkeys(TRANSPORT_KEYS[1:]))))
    assert unflown['transport'] == 'not flown (no TRANSPORT phase)' and 'final position error' not in unflown


def test_a_run_cut_short_prints_no_empty_figure(capture):
    cut = dict(capture, outcome='INTERRUPTED', final_phase='ESTIMATION', phase_sequence=['ESTIMATION'],
               method=None, t_grasp_s=None, capture_position_error_m=None, capture_velocity_error_mps=None,
               min_clearance_m=None, wall_time_s=float('nan'), real_time_factor=None,
               faults_injected={'abort_at_s': 300.0, 'kill': 'flyby_guidance@200'}, nodes_killed=['flyby_planner'])
    table = rows(format_summary(cut))
    for label in ('method', 'grasp time', 'capture position error', 'min clearance', 'wall time', 'real-time factor'):
        assert label not in table, label
    assert table['faults injected'] == 'abort at 300 s, kill flyby_guidance@200'
    assert table['nodes killed'] == 'flyby_planner'


def test_two_chasers_print_each_chasers_figures_and_their_least_separation(capture):
    second = dict(capture, capture_position_error_m=0.02, delta_v_total_mps=1.0)
    fleet = combine({'chaser1': capture, 'chaser2': second}, 5.25, 63.0, ('chaser1', 'chaser2'), False)
    text = format_fleet_summary(fleet)
    table = rows(text)
    assert table['min separation'] == '5.25 m at t = 63 s (chaser1 - chaser2)'
    assert table['delta-v, every chaser'] == f"{capture['delta_v_total_mps'] + 1.0:.4g} m/s"
    lines = text.splitlines()
    first, other = lines.index('chaser1'), lines.index('chaser2')
    assert first < other
    assert any(line.startswith('  capture position error') and
               line.endswith(f"{capture['capture_position_error_m']:.4g} m") for line in lines[first:other])
    assert any(line.startswith('  capture position error') and line.endswith('0.02 m') for line in lines[other:])
    assert text.count('outcome') == 3  # the fleet's and each chaser's
