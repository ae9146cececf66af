"""The cases of scripts/bench/benchmark_pointing.py: seed 001's servicer on three wheels, the fly-by path, the
report line, momentum dumping and the cost of one guidance command."""

import math
import time

import numpy as np

from flyby_guidance.attitude_guidance import (
    AttitudeGuidance,
    AttitudeGuidanceConfig,
    LineOfSightGoal,
    simulate_pointing,
)
from flyby_sim.dynamics.actuators import allocate_wrench, default_thruster_layout, fire
from flyby_sim.dynamics.orbital import cw_coast, mean_motion_rad_s
from flyby_sim.dynamics.rigid_body import GyrostatPropagator, ReactionWheels

SEED001_SERVICER = np.diag([13.0, 38.0, 35.0])
WHEELS = ReactionWheels.orthogonal(max_torque_n_m=0.1, max_momentum_n_m_s=4.0, spin_inertia_kg_m2=0.01)
N = mean_motion_rad_s(7.0e6)
SPHERE_M = 15.0
ATTITUDE_SIGMA_RAD = math.radians(0.01)
RATE_SIGMA_RAD_S = 1e-5


def flyby_path(closest_m, speed_mps, t_closest_s):
    """path(t) -> (r_hill, v_hill): a CW coast through a closest approach of closest_m at speed_mps at t_closest_s,
    11 deg from R-bar."""
    r_closest = closest_m * np.array([0.0, 1.0, -5.0]) / math.sqrt(26.0)
    v_closest = np.array([speed_mps, 0.0, 0.0])

    def path(t):
        state = cw_coast(r_closest, v_closest, t - t_closest_s, N)
        return state[:3], state[3:]
    return path


def report(label, run, start_s=-math.inf, end_s=math.inf):
    """One line of figures of a simulate_pointing run between start_s and end_s."""
    window = (run.t_s >= start_s) & (run.t_s <= end_s)
    err = np.degrees(run.pointing_error_rad[window])
    h_peak = np.abs(run.h_wheels_n_m_s).max(axis=0)
    u_peak = np.abs(run.wheel_torque_n_m).max(axis=0)
    fired = np.abs(run.thruster_torque_body_n_m).max()
    print(f'{label}: pointing error p50 {np.percentile(err, 50):.4f}, p95 {np.percentile(err, 95):.4f}, '
          f'max {err.max():.4f} deg; peak line-of-sight rate {math.degrees(run.los_rate_rad_s[window].max()):.2f} '
          f'deg/s; peak wheel momentum {h_peak.max():.3f} N m s (per wheel {np.round(h_peak, 3).tolist()}); '
          f'peak wheel torque {u_peak.max():.4f} N m (per wheel {np.round(u_peak, 4).tolist()}); '
          f'saturated periods {run.saturated_steps}, momentum-limited {run.momentum_limited_steps}; '
          f'largest thruster torque {fired:.3f} N m')


def dumping():
    """Momentum dumping from 30 m on V-bar (module doc of benchmark_pointing.py)."""
    guidance = AttitudeGuidance(AttitudeGuidanceConfig(), SEED001_SERVICER, WHEELS)
    h0 = np.array([1.5, -1.2, 0.8])

    def at_rest(_t):
        return np.array([30.0, 0.0, 0.0]), np.zeros(3)
    run = simulate_pointing(guidance, GyrostatPropagator(SEED001_SERVICER, WHEELS), at_rest, 0.0, 60.0, N,
                            rng=np.random.default_rng(13), attitude_sigma_rad=ATTITUDE_SIGMA_RAD,
                            rate_sigma_rad_s=RATE_SIGMA_RAD_S, restriction_sphere_radius_m=SPHERE_M,
                            h_wheels0_n_m_s=h0)
    fired = np.any(run.thruster_torque_body_n_m != 0.0, axis=1)
    end = int(np.flatnonzero(fired)[-1]) + 1
    layout = default_thruster_layout()
    firings = {}
    impulse_n_s = fuel_kg = 0.0
    for torque in run.thruster_torque_body_n_m[fired]:
        key = tuple(torque.tolist())
        if key not in firings:
            firings[key] = fire(layout, allocate_wrench(layout, np.zeros(3), torque).thrusts_n,
                                guidance.config.control_period_s)
        impulse_n_s += float(firings[key].impulses_n_s.sum())
        fuel_kg += firings[key].fuel_kg
    print(f'dumping (1.5, -1.2, 0.8) N m s from 30 m: every axis within 0.2 N m s after {run.t_s[end]:.1f} s '
          f'(h {np.round(run.h_wheels_n_m_s[end], 3).tolist()} N m s), {int(fired.sum())} periods firing at '
          f'{np.abs(run.thruster_torque_body_n_m).max():.3f} N m per axis; pointing error max '
          f'{math.degrees(run.pointing_error_rad.max()):.4f} deg; thruster impulse {impulse_n_s:.2f} N s, fuel '
          f'{fuel_kg * 1e3:.2f} g')


def command_cost():
    """The wall time of one AttitudeGuidance.command."""
    guidance = AttitudeGuidance(AttitudeGuidanceConfig(), SEED001_SERVICER, WHEELS)
    path = flyby_path(5.0, 0.2, 150.0)
    r, v = path(100.0)
    q = LineOfSightGoal().update(0.0, r, v, N).q_hill_from_goal
    h = np.array([0.1, -0.2, 0.3])
    calls = 2000
    t0 = time.perf_counter()
    for k in range(calls):
        t = 100.0 + 0.1 * k
        r, v = path(t)
        guidance.command(t, q, np.zeros(3), h, r, v, N, False)
    print(f'AttitudeGuidance.command: {(time.perf_counter() - t0) / calls * 1e6:.0f} us a call')
