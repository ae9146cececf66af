"""Summary figures from truth thrust samples, checked against the rocket equation by hand."""

import numpy as np
import pytest

from flyby_planner.summary import outcome_of, thrust_figures
from flyby_sim.dynamics.constants import STANDARD_GRAVITY_M_S2 as G0_MPS2


def test_constant_burn_delta_v_and_fuel():
    t = np.arange(0.0, 10.0 + 1e-9, 0.05)
    force = np.zeros((len(t), 3))
    force[21:41] = [10.0, 0.0, 0.0]  # 1 s at 10 N
    r = np.tile([50.0, 0.0, 0.0], (len(t), 1))
    dv, fuel, inside = thrust_figures(t, force, r, 100.0, 220.0, 15.0)
    fuel_exact = 10.0 * 1.0 / (220.0 * G0_MPS2)
    assert fuel == pytest.approx(fuel_exact, rel=1e-9)
    assert dv == pytest.approx(220.0 * G0_MPS2 * np.log(100.0 / (100.0 - fuel_exact)), rel=1e-9)
    assert inside is False
    r[30] = [10.0, 0.0, 0.0]
    assert thrust_figures(t, force, r, 100.0, 220.0, 15.0)[2] is True


def test_outcomes():
    assert outcome_of('interrupted', ['ESTIMATION']) == 'INTERRUPTED'
    assert outcome_of('error: node x exited with code 1', []) == 'ERROR'
    assert outcome_of('phase COMPLETE', ['FLYBY', 'CAPTURE', 'COMPLETE']) == 'CAPTURE'
    assert outcome_of('phase COMPLETE', ['FLYBY', 'ESCAPE', 'COMPLETE']) == 'ESCAPE'
    assert outcome_of('phase ABORTED', ['FLYBY', 'ABORTED']) == 'ABORTED'
    assert outcome_of('time_limit', []) == 'TIME_LIMIT'
