#!/usr/bin/env python3
"""Benchmark: the cost of one ``Plant.step`` with the point-mass chaser and with the six-degree-of-freedom chaser.

    benchmark_plant_6dof.py [--steps 6000]

Prints (does not assert) the mean wall time per 0.05 s step of scenarios/paper_flyby.yaml (point mass) and of
scenarios/paper_flyby_6dof.yaml (rigid body) in these cases:

- coast: no command, the chaser at rest in inertial space (the default);
- nominal fly-by: a rate of 0.5 deg/s, the wheels holding 1 N m s each, a wheel command every 0.1 s (the
  attitude loop on the wheels) and a momentum-dumping torque on the thrusters switched on or off every 10 s
  (one allocation each, about 2.5-5 ms);
- thrusting: a wrench held that fires four thrusters at once, every step integrated with the translation;
- fast: 0.3 rad/s about every axis (the property tests' bound), where the attitude takes substeps.

The first step of each case (start-up) is left out. The machine may be shared (a campaign on both cores): each
case runs in five blocks and the line shows the mean of the fastest block and of all. docs/chaser_6dof.md gives
the figures and the command.
"""

import argparse
import dataclasses
import math
import time
from pathlib import Path

from flyby_sim.plant import Plant, PlantConfig
from flyby_sim.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[2]


def cost_us(config, steps, commands=None, blocks=5):
    """(fastest block's, overall) mean wall time per step [us], commands included."""
    plant = Plant(config)
    plant.step()
    per_block = steps // blocks
    means = []
    for b in range(blocks):
        elapsed = 0.0
        for k in range(b * per_block, (b + 1) * per_block):
            t0 = time.perf_counter()
            if commands is not None:
                commands(plant, k)
            plant.step()
            elapsed += time.perf_counter() - t0
            plant.drain_events()
        means.append(elapsed / per_block * 1e6)
    return min(means), sum(means) / blocks


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--steps', type=int, default=6000)
    args = ap.parse_args()
    point = PlantConfig.from_scenario(load_scenario(ROOT / 'scenarios' / 'paper_flyby.yaml'))
    rigid = PlantConfig.from_scenario(load_scenario(ROOT / 'scenarios' / 'paper_flyby_6dof.yaml'))
    body = rigid.chaser_body
    nominal = dataclasses.replace(rigid, chaser_body=dataclasses.replace(
        body, omega_body0=(0.0, math.radians(0.5), 0.0), wheel_momentum0_n_m_s=(1.0, 1.0, 1.0)))
    fast = dataclasses.replace(rigid, chaser_body=dataclasses.replace(body, omega_body0=(0.3, -0.3, 0.3)))

    def attitude_loop(plant, k):
        t = plant.t + 0.05
        if k % 2 == 0:
            plant.command_wheels(t, [0.01 * math.sin(0.01 * k), -0.01, 0.005])
        if k % 200 == 0:
            plant.command_wrench(t, [0.0, 0.0, 0.0], [0.0, 0.0, 0.3 * math.sin(0.001 * k) if k % 400 == 0 else 0.0])

    def thrusting(plant, k):
        if k == 0:
            plant.command_wrench(plant.t, [0.2, 0.0, 0.0], [0.0, 0.0, 0.05])

    cases = (('point mass, coast', point, None),
             ('rigid body, coast', rigid, None),
             ('rigid body, nominal fly-by (commands included)', nominal, attitude_loop),
             ('rigid body, thrusting every step', rigid, thrusting),
             ('rigid body, 0.52 rad/s', fast, None))
    for label, config, commands in cases:
        fastest, mean = cost_us(config, args.steps, commands)
        print(f'{label:48s} {fastest:7.1f} us per {config.step_s} s step (all blocks: {mean:.1f})')


if __name__ == '__main__':
    main()
