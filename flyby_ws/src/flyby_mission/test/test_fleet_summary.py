"""The summary of several chasers (flyby_mission.fleet_summary; DESIGN §10, seed 003 Fig 12)."""

import numpy as np
import pytest

from flyby_mission.fleet_summary import combine, separation
from flyby_msgs_py import contract as c


def test_two_robot_separation_by_hand():
    """Two envelopes of 0.5 m closing along x at 1 m/s from 10 m apart: the least separation is at the last stamp,
    |dx| - 1 m; crossing through each other is a collision."""
    t = np.arange(0.0, 4.01, 0.5)
    a = np.stack([5.0 - 0.5 * t, np.zeros_like(t), np.zeros_like(t)], axis=1)
    b = -a
    sep, t_min, pair, collided = separation({'one': (t, a), 'two': (t, b)}, {'one': 0.5, 'two': 0.5})
    assert sep == pytest.approx(2.0 * 3.0 - 1.0) and t_min == 4.0 and pair == ('one', 'two') and not collided
    t2 = np.arange(0.0, 10.01, 0.5)
    a2 = np.stack([5.0 - t2, np.zeros_like(t2), np.zeros_like(t2)], axis=1)
    sep, t_min, _, collided = separation({'one': (t2, a2), 'two': (t2, -a2)}, {'one': 0.5, 'two': 0.5})
    assert sep == pytest.approx(-1.0) and t_min == 5.0 and collided


def test_separation_only_at_common_stamps():
    t_a, t_b = np.array([0.0, 1.0, 2.0]), np.array([1.0, 2.0, 3.0])
    r = np.zeros((3, 3))
    r_b = np.array([[3.0, 0, 0], [4.0, 0, 0], [0.0, 0, 0]])  # at 3 s on top of a, which has no sample there
    sep, t_min, _, collided = separation({'a': (t_a, r), 'b': (t_b, r_b)}, {'a': 1.0, 'b': 1.0})
    assert sep == pytest.approx(1.0) and t_min == 1.0 and not collided


def _one(outcome, **kw):
    base = {'outcome': outcome, 'delta_v_total_mps': 3.0, 'fuel_used_kg': 0.2, 'maneuvers_executed': 0,
            'late_maneuvers': 0, 'rejected_maneuvers': 0, 'planning_time_s': 1.0, 'capture_position_error_m': 0.04,
            'capture_velocity_error_mps': 0.003, 'min_clearance_m': 0.5, 't_min_clearance_s': 120.0,
            'thrust_inside_restriction_sphere': False}
    base.update(kw)
    return base


def test_outcome_capture_only_when_every_chaser_captured():
    both = combine({'a': _one(c.OUTCOME_CAPTURE), 'b': _one(c.OUTCOME_CAPTURE, min_clearance_m=0.4)}, 5.0, 60.0,
                   ('a', 'b'), False)
    assert both['outcome'] == c.OUTCOME_CAPTURE and both['delta_v_total_mps'] == 6.0
    assert both['min_clearance_m'] == 0.4 and set(both['chasers']) == {'a', 'b'} and both['min_separation_m'] == 5.0
    one = combine({'a': _one(c.OUTCOME_CAPTURE), 'b': _one(c.OUTCOME_ESCAPE)}, 5.0, 60.0, ('a', 'b'), False)
    assert one['outcome'] == c.OUTCOME_ESCAPE
    hit = combine({'a': _one(c.OUTCOME_CAPTURE), 'b': _one(c.OUTCOME_CAPTURE)}, -0.1, 60.0, ('a', 'b'), True)
    assert hit['outcome'] == c.OUTCOME_COLLISION
