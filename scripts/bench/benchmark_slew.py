#!/usr/bin/env python3
"""Benchmark of the six-degree-of-freedom chaser's cores: a 90 deg wheel slew, the propagator, the allocation.

    benchmark_slew.py

Seed 001's servicer (inertia diag(13, 38, 35) kg m^2, Table 1) on three orthogonal wheels (0.1 N m,
4 N m s, spin inertia 0.01 kg m^2), quaternion feedback with omega_n = 0.2 rad/s, zeta = 1,
omega_max = 0.05 rad/s, commands held 0.1 s: prints the settling time within 0.1 deg and the peak wheel
momentum of a 90 deg slew about body y (the largest moment) and about (1, -2, 2)/3; the error tracking a
goal that turns at 0.02 rad/s about body y, with the feed-forward and without it (the closed-form lag
(k_d / k_p) omega_goal); the propagator's cost per simulated second and its torque-free conservation over
1000 s; the cost of one thrust allocation. docs/chaser_6dof.md and docs/guidance.md quote these figures.
"""

import math
import time

import numpy as np

from flyby_sim.dynamics.actuators import allocate_wrench, default_thruster_layout
from flyby_sim.dynamics.attitude import kinetic_energy
from flyby_sim.dynamics.attitude_control import (
    QuaternionFeedbackController,
    attitude_error_rotation_vector,
    simulate_slew,
)
from flyby_sim.dynamics.rigid_body import (
    ChaserAttitudeState,
    GyrostatPropagator,
    ReactionWheels,
    total_angular_momentum_inertial,
)
from flyby_sim.dynamics.rotation import quat_from_axis_angle, quat_from_rotation_vector, quat_normalize

SEED001_SERVICER = np.diag([13.0, 38.0, 35.0])
WHEELS = ReactionWheels.orthogonal(max_torque_n_m=0.1, max_momentum_n_m_s=4.0, spin_inertia_kg_m2=0.01)
PERIOD_S = 0.1


def slews(propagator):
    controller = QuaternionFeedbackController(SEED001_SERVICER, WHEELS, 0.2, 1.0, 0.05)
    for axis in ((0.0, 1.0, 0.0), (1.0, -2.0, 2.0)):
        t0 = time.perf_counter()
        result = simulate_slew(propagator, controller, [0.0, 0.0, 0.0, 1.0], quat_from_axis_angle(axis, math.pi / 2),
                               duration_s=150.0, period_s=PERIOD_S)
        wall_s = time.perf_counter() - t0
        peak_per_wheel = np.max(np.abs(result.h_wheels_n_m_s), axis=0)
        print(f'90 deg slew about {axis}: settled within 0.1 deg at {result.settling_time_s(0.1):.1f} s; '
              f'peak wheel momentum {result.peak_wheel_momentum_n_m_s:.3f} N m s (per wheel '
              f'{np.round(peak_per_wheel, 3).tolist()}); peak rate '
              f'{math.degrees(np.max(np.linalg.norm(result.omega_body, axis=1))):.2f} deg/s; error at 150 s '
              f'{result.error_deg[-1]:.1e} deg; torque-limited periods {result.torque_limited_steps}, '
              f'momentum-limited {result.momentum_limited_steps}; |H - H0| <= '
              f'{result.momentum_error_n_m_s.max():.1e} N m s; {wall_s / 150.0 * 1e3:.1f} ms per simulated s')


def tracking(propagator):
    """A goal turning at 0.02 rad/s about body y from q = 1, the chaser 5 deg off about (1, 1, 0) and at rest."""
    controller = QuaternionFeedbackController(SEED001_SERVICER, WHEELS, 0.2, 1.0, 0.05)
    omega_goal = np.array([0.0, 0.02, 0.0])
    for feed_forward in (True, False):
        state = ChaserAttitudeState(quat_from_axis_angle([1.0, 1.0, 0.0], math.radians(5.0)), np.zeros(3),
                                    np.zeros(3))
        errors = []
        for k in range(int(round(150.0 / PERIOD_S)) + 1):
            q_goal = quat_from_rotation_vector(omega_goal * (k * PERIOD_S))
            errors.append(math.degrees(np.linalg.norm(attitude_error_rotation_vector(state.q_inertial_from_body,
                                                                                     q_goal))))
            ff = (omega_goal, np.zeros(3)) if feed_forward else (None, None)
            torque = controller.body_torque(state.q_inertial_from_body, state.omega_body, state.h_wheels_n_m_s,
                                            q_goal, *ff)
            state = propagator.step(state, PERIOD_S, (0.0, 0.0, 0.0), controller.wheel_torque_for(torque)).state
        settled = next((k * PERIOD_S for k in range(len(errors)) if max(errors[k:]) <= 0.1), math.inf)
        lag = math.degrees(controller.k_d / controller.k_p * 0.02)
        print(f'tracking a goal turning at 0.02 rad/s about y {"with" if feed_forward else "without"} feed-forward: '
              f'error at 150 s {errors[-1]:.3g} deg (closed-form lag without: {lag:.3f} deg); within 0.1 deg from '
              f'{settled:.1f} s; wheel momentum at 150 s {np.max(np.abs(state.h_wheels_n_m_s)):.3f} N m s')


def torque_free(propagator):
    state0 = ChaserAttitudeState(quat_normalize([0.1, 0.2, -0.3, 0.9]), np.array([0.1, -0.2, 0.15]),
                                 np.array([0.5, -0.3, 1.0]))
    h0 = total_angular_momentum_inertial(state0, SEED001_SERVICER, WHEELS)
    energy0 = kinetic_energy(state0.omega_body, SEED001_SERVICER)
    for dt_s in (1.0, PERIOD_S):
        state, worst_h, worst_energy = state0, 0.0, 0.0
        t0 = time.perf_counter()
        for _ in range(int(round(1000.0 / dt_s))):
            state = propagator.step(state, dt_s, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)).state
            h = total_angular_momentum_inertial(state, SEED001_SERVICER, WHEELS)
            worst_h = max(worst_h, float(np.linalg.norm(h - h0) / np.linalg.norm(h0)))
            energy = kinetic_energy(state.omega_body, SEED001_SERVICER)
            worst_energy = max(worst_energy, abs(energy - energy0) / energy0)
        wall_s = time.perf_counter() - t0
        print(f'torque-free, 1000 s in {dt_s} s steps: {wall_s:.2f} s wall '
              f'({wall_s / 1000.0 * 1e3:.2f} ms per simulated s, diagnostics included); '
              f'max relative drift: momentum {worst_h:.1e}, energy {worst_energy:.1e}')


def allocation():
    layout = default_thruster_layout()
    rng = np.random.default_rng(1)
    wrenches = layout.wrench_matrix @ rng.uniform(0.0, 10.0, size=(12, 200))
    t0 = time.perf_counter()
    worst = max(float(np.max(np.abs(allocate_wrench(layout, w[:3], w[3:]).wrench_undelivered_body)))
                for w in wrenches.T)
    print(f'allocation of 200 achievable wrenches: {(time.perf_counter() - t0) / 200 * 1e3:.2f} ms each, '
          f'largest residual {worst:.1e} (N, N m)')


def main():
    propagator = GyrostatPropagator(SEED001_SERVICER, WHEELS)
    slews(propagator)
    tracking(propagator)
    torque_free(propagator)
    allocation()


if __name__ == '__main__':
    main()
