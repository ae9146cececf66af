"""The independent collision-avoidance monitor (flyby_mission.cam_monitor): it fires on a coast into the target's
real geometry from raw, noisy samples, stays silent on a pass that clears it, stands down at the capture, fires
once; the plant executes its CAM ahead of every command and ignores the planning chain's thrust after it."""

from pathlib import Path

import numpy as np

from flyby_mission.cam_monitor import HORIZON_S, CamBurn, CamMonitor, CamParams
from flyby_msgs_py import contract as c
from flyby_msgs_py import events
from flyby_sim.dynamics.geometry import clearance
from flyby_sim.dynamics.orbital import cw_transition_matrix
from flyby_sim.dynamics.rotation import quat_from_rotation_vector, quat_multiply
from flyby_sim.plant import Plant, PlantConfig
from flyby_sim.scenario import load_scenario

REPO = Path(__file__).resolve().parents[4]
SCENARIO = load_scenario(REPO / 'scenarios' / 'paper_flyby_6dof.yaml')
PARAMS = CamParams.from_scenario(SCENARIO)
OMEGA_HILL = np.radians([0.0, 1.0, 4.0])  # the target turns at about 4 deg/s


def _fly(r0, v0, duration_s, seed=0, phase_at=None):
    """The monitor fed 10 Hz samples of a CW coast from (r0, v0) and of a target turning at OMEGA_HILL, with the
    sensors' noise (1 cm, 1 deg); its outputs and the true least clearance before each."""
    rng = np.random.default_rng(seed)
    monitor = CamMonitor(PARAMS)
    outputs, gaps = [], []
    x0 = np.concatenate((r0, v0))
    for k in range(1, int(duration_s * 10) + 1):
        t = 0.1 * k
        r = (cw_transition_matrix(PARAMS.mean_motion_rad_s, t) @ x0)[:3]
        q = quat_from_rotation_vector(OMEGA_HILL * t)
        gaps.append(float(clearance(r[None], q, PARAMS.boxes, PARAMS.envelope_radius_m)[0]))
        if phase_at is not None and t >= phase_at:
            monitor.on_phase(c.PHASE_CAPTURE)
        monitor.on_attitude(t, quat_multiply(quat_from_rotation_vector(np.radians(1.0) * rng.standard_normal(3)), q))
        outputs += [(t, o) for o in monitor.on_position(t, r + 0.01 * rng.standard_normal(3))]
    return outputs, np.array(gaps)


def test_a_coast_into_the_target_fires_one_cam_away_before_the_contact():
    r0, v0 = np.array([12.0, 1.0, 0.5]), np.array([-0.3, 0.0, 0.0])
    outputs, gaps = _fly(r0, v0, 60.0)
    contact = 0.1 * (int(np.argmax(gaps < 0.0)) + 1)
    burns = [(t, o) for t, o in outputs if isinstance(o, CamBurn)]
    assert len(burns) == 1 and [o.name for _, o in outputs if not isinstance(o, CamBurn)] == [events.CAM_FIRED]
    t_fire, burn = burns[0]
    assert contact - HORIZON_S - 0.5 <= t_fire < contact - 1.0  # within its horizon, ahead of the contact
    away = burn.dv_hill / np.linalg.norm(burn.dv_hill)  # along the line from the CoM: its closing speed and more
    assert away[0] > 0.9 and float(burn.dv_hill @ v0) < -0.8 * float(v0 @ v0)
    assert np.linalg.norm(burn.dv_hill) > 0.25 + PARAMS.avoidance_delta_v_mps


def test_a_pass_that_clears_the_geometry_and_a_captured_chaser_fire_nothing():
    for seed in range(5):  # 3 m to the side of the CoM: about 0.7 m of clearance at the closest
        outputs, gaps = _fly(np.array([12.0, 3.0, 0.0]), np.array([-0.2, 0.0, 0.0]), 100.0, seed=seed)
        assert gaps.min() > 0.3 and outputs == []
    outputs, _ = _fly(np.array([12.0, 1.0, 0.5]), np.array([-0.3, 0.0, 0.0]), 60.0, phase_at=5.0)
    assert outputs == []


def test_the_plant_flies_the_cam_ahead_of_the_queue_and_ignores_the_chain_after_it():
    """A maneuver queued before the CAM and one commanded after it change nothing: the chaser flies as with the CAM
    alone."""
    runs = []
    for chain in (False, True):
        plant = Plant(PlantConfig.from_scenario(SCENARIO))
        if chain:
            plant.command_maneuver(5.0, (0.0, 0.0, 0.05))
        plant.command_cam(1.0, np.array([0.2, 0.0, 0.0]))
        if chain:
            assert plant.command_maneuver(2.0, (0.0, 0.1, 0.0)) is None
        names = []
        while plant.t < 60.0:
            plant.step()
            names += [e.name for e in plant.drain_events()]
        runs.append(plant.truth().v_hill)
        assert names.count(events.CAM_EXECUTED) == 1 and names.count(events.BURN_STARTED) == 1
    np.testing.assert_allclose(runs[1], runs[0], atol=1e-12)


def test_a_cam_the_remaining_thrusters_cannot_fly_when_it_starts_leaves_them_to_the_chain():
    """The CAM accepted, then every thruster pushing along it closed before its start: its burn is refused there
    (maneuver_rejected) and the planning chain's commands are flown again."""
    from flyby_sim.dynamics.rotation import quat_conjugate, quat_rotate

    plant = Plant(PlantConfig.from_scenario(SCENARIO))
    dv_hill = np.array([0.2, 0.0, 0.0])
    plant.command_cam(1.0, dv_hill)
    along_body = quat_rotate(quat_conjugate(plant.truth().q_hill_from_body), dv_hill)
    plant.isolate_thrusters(np.flatnonzero(plant.chaser.layout.force_directions_body @ along_body > 0.0))
    names = []
    while plant.t < 3.0:
        plant.step()
        names += [e.name for e in plant.drain_events()]
    assert events.MANEUVER_REJECTED in names and events.BURN_STARTED not in names
    assert plant.command_maneuver(5.0, -dv_hill) is not None  # None: ignored after a CAM
    plant.command_wrench(6.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.01))
    while plant.t < 10.0:
        plant.step()
        names += [e.name for e in plant.drain_events()]
    assert events.COMMAND_IGNORED not in names
