"""One short seeded run of the target attitude filter on the plant (scripts/estimation_consistency.py runs many)."""

from pathlib import Path

import numpy as np

from flyby_mission.estimation_consistency import run_one

SCENARIO = Path(__file__).resolve().parents[4] / 'scenarios' / 'paper_flyby.yaml'


def test_one_run_samples_every_second_and_is_seeded():
    times, nees, accuracy, rejected = run_one(SCENARIO, 3, 12.0, 60.0, accuracy_time_s=10.0)
    assert np.allclose(times, np.arange(1.0, 13.0))
    assert np.all(nees > 0.0)
    assert accuracy['grasp_sigma_m'] > 0.0 and 0.0 < accuracy['ratio_min'] <= accuracy['ratio_max']
    assert set(rejected.values()) == {0}
    again = run_one(SCENARIO, 3, 12.0, 60.0, accuracy_time_s=10.0)
    assert np.array_equal(again[1], nees)
