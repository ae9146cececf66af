"""The transport planner on its two cases, figures printed (not asserted).

Seed 004 §3.2's V-bar advance (7000 km orbit, from rest, 3000 s): the TugRobot's combined satellite (seed 004 §3.1,
50 kg) by 1 km and paper_flyby_tug's combined body (1600 kg, CoM ~2.9 m out on +x) by 100 m, each with its layout
less the thrusters pushing along -x; then two refusals and their reasons.

    .venv/bin/python scripts/bench/benchmark_transport.py
"""

import time

import numpy as np

from flyby_planner.transport.model import TransportBody, TransportConfig, TransportRefused, TransportState
from flyby_planner.transport.plan import plan_transport
from flyby_planner.transport.thrusters import push_axis
from flyby_sim.dynamics.actuators import ThrusterLayout, default_thruster_layout
from flyby_sim.dynamics.combined_body import combined_mass_properties, inertia_from_principal
from flyby_sim.dynamics.rotation import quat_from_axis_angle


def without_minus_x(layout):
    keep = layout.force_directions_body[:, 0] > -0.5
    return ThrusterLayout(layout.positions_body_m[keep], layout.force_directions_body[keep], layout.max_thrust_n[keep],
                          layout.isp_s, layout.min_impulse_bit_n_s)


def cases():
    props = combined_mass_properties(30.0, np.diag([2.0, 3.0, 3.0]), 20.0, (0.5, 0.0, 0.0), np.diag([2.0, 1.5, 1.5]))
    yield ('tugrobot 1 km', TransportBody(props.mass_kg, props.com_body_m, props.inertia_body_kg_m2,
                                          without_minus_x(default_thruster_layout(face_m=0.2, lever_arm_m=0.15))),
           (1000.0, 0.0, 0.0))
    i_target = inertia_from_principal((1200.0, 1000.0, 2000.0), quat_from_axis_angle((0.2, 0.3, 1.0), 0.5))
    props = combined_mass_properties(100.0, 10.0 * np.eye(3), 1500.0, (3.12, 0.02, -0.01), i_target)
    yield ('paper_flyby_tug 100 m', TransportBody(props.mass_kg, props.com_body_m, props.inertia_body_kg_m2,
                                                  without_minus_x(default_thruster_layout())), (100.0, 0.0, 0.0))


def main():
    config = TransportConfig()
    state = TransportState(0.0, np.zeros(3), np.zeros(3), np.array([0.0, 0.0, 1.0, 0.0]), np.zeros(3))
    for name, body, goal in cases():
        axis, force_n = push_axis(body)
        times = []
        for _ in range(3):
            start = time.perf_counter()
            plan = plan_transport(body, state, goal, 3000.0, config)
            times.append(time.perf_counter() - start)
        print(f'{name}: mass {body.mass_kg:.0f} kg, CoM {np.round(body.com_body_m, 3).tolist()} m, push axis '
              f'{axis.tolist()} ({force_n:.2f} N pure)')
        print(f'  planning time {min(times):.2f} s (best of 3; {", ".join(f"{t:.2f}" for t in times)})')
        print(f'  {plan.impulses} burns, fuel {plan.fuel_kg:.4f} kg, arrival {plan.t_arrival_s:.1f} s')
        for burn in plan.burns:
            print(f'    {burn.purpose:10s} {burn.t_start_s:8.1f} s {burn.duration_s:5.1f} s  '
                  f'F {np.round(burn.force_body_n, 3)} N  T_chaser {np.round(burn.torque_body_n_m, 3)} N m')
        print('  predicted: ' + ', '.join(f'{k} {v:.3g}' for k, v in plan.conditions.items()))
    for name, body, goal, t_arr in (('tug, 200 km in 1500 s', list(cases())[1][1], (2.0e5, 0.0, 0.0), 1500.0),
                                    ('tugrobot, 100 m in 400 s', list(cases())[0][1], (100.0, 0.0, 0.0), 400.0)):
        try:
            plan_transport(body, state, goal, t_arr, config)
            print(f'{name}: planned (unexpected)')
        except TransportRefused as refused:
            print(f'{name}: refused: {refused.reason}')


if __name__ == '__main__':
    main()
