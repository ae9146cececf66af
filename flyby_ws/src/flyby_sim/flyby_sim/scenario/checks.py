"""Scenario checks that a range cannot express: of one key (inertia, names, rows) and across keys (resolved dict).

Each raises or returns the problem as ``flyby_msgs_py.schema`` expects: a field check returns a message (or
None), a cross check raises ``Invalid`` naming the dotted key.
"""

import math

import numpy as np

from flyby_msgs_py.schema import Invalid, format_floats
from flyby_sim.dynamics.actuators import ThrusterLayout, is_positively_spanning
from flyby_sim.faults import check_faults


def check_inertia(m):
    a = np.asarray(m, dtype=float)
    scale = np.max(np.abs(a))
    for i, j in ((0, 1), (0, 2), (1, 2)):
        if abs(a[i, j] - a[j, i]) > 1e-9 * scale:
            return f'must be symmetric, got [{i}][{j}] = {a[i, j]!r} but [{j}][{i}] = {a[j, i]!r}'
    moments = np.linalg.eigvalsh(0.5 * (a + a.T))
    if moments[0] <= 0.0:
        return f'must be positive definite, got principal moments {format_floats(moments)}'
    if moments[0] + moments[1] < moments[2] * (1.0 - 1e-12):
        return (f'principal moments {format_floats(moments)} violate the triangle inequality '
                f'(I1 + I2 >= I3 for any rigid body)')
    return None


def check_unique_names(items):
    seen = {}
    for i, item in enumerate(items):
        if item['name'] in seen:
            return i, 'name', f'duplicate box name {item["name"]!r} (also at index {seen[item["name"]]})'
        seen[item['name']] = i
    return None


MIN_WHEEL_SPAN = 1e-3  # no three unit wheel axes within about 0.06 deg of a plane
MIN_DIRECTION_NORM = 1e-6  # a direction or quaternion's norm at least this (normalized on load) ...
MAX_DIRECTION_NORM = 1e6  # ... and at most this: its square neither underflows nor overflows


def check_direction(v):
    """Field check: a direction or quaternion that normalizes, its norm within [MIN_DIRECTION_NORM,
    MAX_DIRECTION_NORM] (a norm of 1e-200 divides to nothing)."""
    if not any(v):
        return 'must be nonzero, got [0.0, 0.0, 0.0]' if len(v) == 3 else f'must be nonzero, got {v}'
    norm = math.hypot(*v)
    if not MIN_DIRECTION_NORM <= norm <= MAX_DIRECTION_NORM:
        return (f'must have a norm within [{MIN_DIRECTION_NORM:g}, {MAX_DIRECTION_NORM:g}] (normalized on load), '
                f'got {format_floats(v)} of norm {norm:.6g}')
    return None


def check_direction_rows(rows):
    """Field check: every row a direction (check_direction)."""
    for i, row in enumerate(rows):
        if not any(row):
            return f'row {i} must be nonzero, got {row}'
        problem = check_direction(row)
        if problem:
            return f'row {i} {problem}'
    return None


def cross_checks(d):
    """Checks across keys, on the resolved dict; raise Invalid."""
    step = d['simulation']['step_s']
    for sensor in ('relative_position', 'target_attitude'):
        rate = d['sensors'][sensor]['rate_hz']
        if rate * step > 1.0 + 1e-9:
            raise Invalid(f'sensors.{sensor}.rate_hz',
                          f'must be <= 1/simulation.step_s = {1.0 / step:g} Hz (a sensor samples at most '
                          f'once per step), got {rate!r}')
    imu = d['sensors']['chaser_imu']
    if imu['rate_hz'] * step > 1.0 + 1e-9:
        raise Invalid('sensors.chaser_imu.rate_hz',
                      f'must be <= 1/simulation.step_s = {1.0 / step:g} Hz (a sensor samples at most '
                      f'once per step), got {imu["rate_hz"]!r}')
    ratio = imu['rate_hz'] / imu['star_tracker_rate_hz']
    if ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-9 * ratio:
        raise Invalid('sensors.chaser_imu.star_tracker_rate_hz',
                      f'must divide sensors.chaser_imu.rate_hz = {imu["rate_hz"]!r} a whole number of times (each '
                      f'star-tracker sample falls on a gyro sample), got {imu["star_tracker_rate_hz"]!r}')
    _check_chaser_body(d['chaser'])
    check_faults(d)
    g = d['guidance']
    if g['momentum_dump_stop_n_m_s'] >= g['momentum_dump_start_n_m_s']:
        raise Invalid('guidance.momentum_dump_stop_n_m_s', f'must be below guidance.momentum_dump_start_n_m_s = '
                                                           f'{g["momentum_dump_start_n_m_s"]!r}, got '
                                                           f'{g["momentum_dump_stop_n_m_s"]!r}')
    planner = d['planner']
    arm = d['chaser']['manipulator']
    usable = arm['reach_m'] - arm['position_tolerance_m']
    for key in ('offset_m', 'offset_max_m'):
        if planner[key] is not None and planner[key] > usable + 1e-12:
            raise Invalid(f'planner.{key}', f'must be <= chaser.manipulator.reach_m - position_tolerance_m = '
                                            f'{usable!r} (the grasp point out of reach at the fly-by target point), '
                                            f'got {planner[key]!r}')
    if planner['offset_max_m'] is not None and planner['offset_max_m'] < planner['offset_m']:
        raise Invalid('planner.offset_max_m', f"must be >= planner.offset_m = {planner['offset_m']!r}, "
                                              f"got {planner['offset_max_m']!r}")
    if planner['transfer_max_s'] < planner['transfer_min_s']:
        raise Invalid('planner.transfer_max_s', f"must be >= planner.transfer_min_s = {planner['transfer_min_s']!r}, "
                                                f"got {planner['transfer_max_s']!r}")
    if planner['method'] in ('optimal', 'sync') and d['chaser']['model'] != 'rigid_body':
        raise Invalid('planner.method', f"{planner['method']} needs chaser.model rigid_body (continuous thrust), got "
                                        f"{d['chaser']['model']!r}")
    sync = planner['sync']
    if sync['arrival_end_s'] <= sync['arrival_start_s']:
        raise Invalid('planner.sync.arrival_end_s', f"must be > planner.sync.arrival_start_s = "
                                                    f"{sync['arrival_start_s']!r}, got {sync['arrival_end_s']!r}")
    if d['post_capture'] is not None and d['chaser']['model'] != 'rigid_body':
        raise Invalid('post_capture', f"needs chaser.model rigid_body (attitude, thrusters and wheels to damp and "
                                      f"excite the combined body), got {d['chaser']['model']!r}")
    _check_start(d)
    optimal = planner['optimal']
    if optimal['approach_time_max_s'] <= optimal['approach_time_min_s']:
        raise Invalid('planner.optimal.approach_time_max_s',
                      f"must be > planner.optimal.approach_time_min_s = {optimal['approach_time_min_s']!r}, "
                      f"got {optimal['approach_time_max_s']!r}")


def _check_start(d):
    """The target's initial state is the scenario's, or derived from the chaser's when the run starts attached."""
    pc = d['post_capture']
    attached = pc is not None and pc['start'] == 'attached'
    for key in ('initial_attitude', 'initial_rate'):
        if attached and d['target'][key] is not None:
            raise Invalid(f'target.{key}', 'must be omitted when post_capture.start is attached (the target turns '
                                           'with the chaser that holds it: derived from chaser.initial_attitude, '
                                           'chaser.initial_rate and post_capture.attachment)')
        if not attached and d['target'][key] is None:
            raise Invalid(f'target.{key}', 'is required (unless post_capture.start is attached)')
    if pc is None:
        return
    if attached and pc['attachment'] is None:
        raise Invalid('post_capture.attachment', 'is required when post_capture.start is attached (where the '
                                                 'target\'s CoM and axes are in chaser_body)')
    if not attached and pc['attachment'] is not None:
        raise Invalid('post_capture.attachment', f"is only for post_capture.start attached, got start "
                                                 f"{pc['start']!r}")
    if attached and pc['mass_estimation']['prior_axes_sigma_deg'] is None:
        raise Invalid('post_capture.mass_estimation.prior_axes_sigma_deg',
                      'is required when post_capture.start is attached (no target attitude estimate to take it from)')


def _check_chaser_body(chaser):
    """Checks of the rigid-body chaser's keys across keys (validated whatever chaser.model says)."""
    layout = chaser['thrusters']['layout']
    if layout is not None:
        th = chaser['thrusters']
        b = ThrusterLayout([x['position_m'] for x in layout], [x['direction'] for x in layout], th['max_thrust_n'],
                           th['isp_s'], th['min_impulse_bit_ns']).wrench_matrix
        if not is_positively_spanning(b):
            raise Invalid('chaser.thrusters.layout',
                          f'the {len(layout)} thrusters must give every body force and torque (rank 6 and '
                          f'positively spanning), got rank {np.linalg.matrix_rank(b)}'
                          + ('' if np.linalg.matrix_rank(b) < 6 else ' but not positively spanning'))
    wheels = chaser['wheels']
    axes = np.array([np.divide(a, math.hypot(*a)) for a in wheels['axes']])
    if len(axes) < 3 or np.linalg.svd(axes, compute_uv=False)[2] < MIN_WHEEL_SPAN:
        raise Invalid('chaser.wheels.axes', f'the wheel axes must span 3 axes (smallest singular value of the unit '
                                            f'axes >= {MIN_WHEEL_SPAN:g}: wheel-only attitude control), got '
                                            f'{[list(a) for a in wheels["axes"]]}')
    h0 = wheels['initial_momentum_n_m_s']
    if h0 is not None:
        if len(h0) != len(wheels['axes']):
            raise Invalid('chaser.wheels.initial_momentum_n_m_s',
                          f'must give one value per wheel axis of chaser.wheels.axes ({len(wheels["axes"])}), got '
                          f'{len(h0)}')
        for i, h in enumerate(h0):
            if abs(h) > wheels['max_momentum_n_m_s']:
                raise Invalid(f'chaser.wheels.initial_momentum_n_m_s[{i}]',
                              f'must be within +-max_momentum_n_m_s = {wheels["max_momentum_n_m_s"]!r}, got {h!r}')

