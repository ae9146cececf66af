"""The grasp and the damping of the post-capture cores, as scripts/bench/benchmark_mass_estimation.py ends
(docs/post_capture.md)."""

import math
import time
from pathlib import Path

import numpy as np

from flyby_guidance.damping import DampingGains, simulate_damping
from flyby_sim.dynamics.actuators import default_thruster_layout
from flyby_sim.dynamics.grasp import Body, Impedance, simulate_grasp
from flyby_sim.dynamics.rigid_body import ChaserAttitudeState, ReactionWheels
from flyby_sim.scenario import load_scenario

# The default arm: the schema's post_capture.grasp, as paper_flyby_tug writes it out.
ARM = Impedance.from_scenario(load_scenario(Path(__file__).resolve().parents[2] / 'scenarios' / 'paper_flyby_tug.yaml'))


def grasp_and_damping():
    """The grasp of a 20 kg target by the default Impedance (and one too fast to hold), then the damping of a
    combined body's spin on the wheels and the thrusters: the figures printed."""
    chaser = Body(100.0, np.diag([8.0, 10.0, 12.0]), np.zeros(3), np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]),
                  np.zeros(3))
    omega_t = math.radians(3.0) * np.array([0.0, 0.6, 0.8])
    r_ee, r_g = np.array([0.8, 0.0, 0.0]), np.array([-0.5, 0.0, 0.0])
    target = Body(20.0, np.diag([2.0, 1.5, 1.5]), r_ee - r_g + np.array([0.005, 0.003, 0.0]),
                  np.array([0.0, 0.0, 0.001]), np.array([0.0, 0.0, 0.0, 1.0]), omega_t)
    t0 = time.perf_counter()
    res = simulate_grasp(chaser, target, ARM, r_ee, r_g, 10.0, output_step_s=0.02)
    print(f'grasp (100 kg chaser, 20 kg target at 3 deg/s, 5.8 mm and 1 mm/s residual, default Impedance): '
          f'peak force {res.peak_force_n:.3f} N, peak torque {res.peak_torque_n_m:.3f} N m, damped after '
          f'{res.damping_time_s:.2f} s, released {res.released}, dissipated {res.dissipated_j[-1] * 1e3:.3f} mJ '
          f'({time.perf_counter() - t0:.1f} s)')
    res = simulate_grasp(chaser, target._replace(v_mps=np.array([0.0, 0.0, 0.5])), ARM, r_ee, r_g, 10.0,
                         output_step_s=0.02)
    print(f'grasp at 0.5 m/s closing speed: released {res.released} at {res.t_release_s} s ({res.release_reason})')
    inertia = np.diag([1200.0, 1000.0, 2000.0]) + np.diag([8.0, 10.0, 12.0])
    omega0 = math.radians(5.0) * np.array([0.0, 0.6, 0.8])
    wheels = ReactionWheels.orthogonal(0.1, 4.0, 0.01)
    state0 = ChaserAttitudeState(np.array([0.0, 0.0, 0.0, 1.0]), omega0, np.array([0.3, -0.2, 0.1]))
    gains = DampingGains.for_inertia_bound(500.0, 1.0, max_thruster_torque_n_m=4.0)
    t0 = time.perf_counter()
    dmp = simulate_damping(inertia, wheels, state0, gains, 600.0, period_s=1.0, layout=default_thruster_layout())
    print(f'damping (paper_flyby target + chaser, 5 deg/s, |H0| {dmp.momentum_kg_m2_s[0]:.1f} kg m^2/s, 1 s period, '
          f'gains from a 500 kg m^2 bound): below 0.1 kg m^2/s after {dmp.time_to_bound_s:.0f} s, fuel '
          f'{dmp.fuel_kg * 1e3:.1f} g ({time.perf_counter() - t0:.1f} s)')
