"""The report's trajectory views (flyby_mission.report.flyby, drawing) on a real graph run that captures and holds the
target (conftest.tug_short_run): the x-z view is scaled to the flown path, not to the planned escape orbit, and the
motion while the chaser holds the target is drawn apart from the free flight, with the target's boxes where it holds
them, not through the boxes of the grasp time as a collision."""

import numpy as np
import pytest

from flyby_mission.report import drawing, loading
from flyby_mission.report.flyby import trajectory_xz_figure
from flyby_mission.report.plotting import plt
from flyby_msgs_py import contract as c
from flyby_testing import read_summary

pytestmark = pytest.mark.slow


@pytest.fixture(scope='module')
def run(tug_short_run):
    return loading.Run(tug_short_run[0])


@pytest.fixture(scope='module')
def axes(run):
    fig = trajectory_xz_figure(run)
    yield fig.axes[0], fig.axes[1]
    plt.close(fig)


def test_the_xz_view_is_scaled_to_the_flown_path(run, axes):
    left, _ = axes
    chaser = run.need(c.SIM_CHASER_ODOM)
    x, z = chaser.position[:, 0], chaser.position[:, 2]
    boxes = np.concatenate(drawing.box_corners_hill(run.scenario, run.target_attitude_at(run.region_time[0])))
    flown = np.concatenate((chaser.position, boxes))  # the path and the target it flies to
    extent = max(np.ptp(flown[:, 0]), np.ptp(flown[:, 2]))
    (x_lo, x_hi), (z_hi, z_lo) = left.get_xlim(), left.get_ylim()
    assert z_hi > z_lo  # z drawn downward: up is away from Earth
    assert x_lo < x.min() and x.max() < x_hi and z_lo < z.min() and z.max() < z_hi
    margin = 1.0 + 2.0 * drawing.PATH_MARGIN
    assert x_hi - x_lo <= margin * extent + 1e-3 and z_hi - z_lo <= margin * extent + 1e-3  # [m]
    planned = run.planned_path()[1]  # the planned escape runs on beyond the flown path, clipped
    assert np.any((planned[:, 0] < x_lo) | (planned[:, 0] > x_hi) | (planned[:, 2] < z_lo) | (planned[:, 2] > z_hi))


def test_the_motion_while_holding_the_target_is_drawn_as_held(run, axes):
    summary = read_summary(run.run_dir)
    t_capture, t_end = run.attached
    assert t_capture == pytest.approx(summary['t_grasp_s'], abs=0.1) and t_end == run.t_end
    chaser = run.need(c.SIM_CHASER_ODOM)
    for ax in axes:
        lines = {line.get_label(): line for line in ax.get_lines()}
        free = lines['chaser truth'].get_xydata()
        held = lines[f'chaser truth, holding the target ({t_capture:.0f}-{t_end:.0f} s)'].get_xydata()
        after = chaser.t > t_capture + 1.0
        assert np.isnan(free[after]).all() and not np.isnan(free[~after & (chaser.t < t_capture)]).any()
        assert np.allclose(held[after], chaser.position[after][:, [0, 2]])
        assert 'target CoM, held' in lines
    labels = [h.get_label() for h in axes[0].patches + axes[0].collections + list(axes[0].get_children())]
    assert f'target boxes at t = {t_end:.0f} s, held' in labels


def test_the_titles_name_the_seed_flown(run):
    assert run.title == f"{run.scenario.name}, seed {read_summary(run.run_dir)['seed']}: CAPTURE"
