"""Physical plausibility of a scenario across keys: each rule states its range, chosen generous enough that every
shipped scenario passes with a wide margin and what it refuses is a typo or a meaningless value, never a design.

``plausible_dict`` runs on the resolved dict before the other cross-key checks and the derived quantities (so that none
of them overflows or divides by zero); ``plausible_view`` on the Scenario, for the rules that need the initial attitude.
Both raise ``Invalid`` naming the dotted key.
"""

import math

import numpy as np

from flyby_msgs_py.schema import Invalid, format_floats
from flyby_sim.dynamics.constants import EARTH_RADIUS_M
from flyby_sim.scenario.schema import MAX_ORBIT_RADIUS_M

MU_RANGE_M3_S2 = (1e10, 1e18)  # a moon or a planet: the Moon 4.9e12, the Earth 3.99e14, Jupiter 1.27e17
MASS_RANGE_KG = (0.1, 1e6)  # a small CubeSat to twice the ISS
INERTIA_RANGE = (1e-3, 1e3)  # principal moments over m L^2 / 12 (L: the body's largest extent)
GRASP_SURFACE_TOLERANCE_M = 0.1  # the grasp point lies within this of a face of the target's geometry
MAX_STEPS = 10_000_000  # simulation.duration_s / simulation.step_s at most this (days of wall time beyond)
MAX_BOX_M = 1e3  # a geometry box's edges and centre coordinates at most this
ENVELOPE_RANGE_M = (0.01, 100.0)  # chaser.envelope_radius_m
MAX_RANGE_M = 1e6  # the chaser's start at most this far from the target (a relative-motion problem)
MAX_SPEED_MPS = 1e3  # the chaser's start velocity relative to hill at most this
THRUSTER_REACH = 10.0  # a thruster within this many chaser.envelope_radius_m of the CoM (booms allowed)
MAX_RATE_RAD_S = 2.0 * math.pi  # an initial angular velocity at most one turn a second


def plausible_dict(d):
    """The rules on the resolved dict (module doc); raise Invalid."""
    _check_orbit(d['orbit'])
    _check_simulation(d['simulation'])
    target, chaser = d['target'], d['chaser']
    _check_sizes(target, chaser)
    for who in ('target', 'chaser'):
        if d[who]['initial_rate'] is not None:
            _check_rate(f'{who}.initial_rate', d[who]['initial_rate'])
    _check_mass('target.mass_kg', target['mass_kg'])
    _check_mass('chaser.mass_kg', chaser['mass_kg'])
    boxes = target['geometry']
    lo = np.min([np.subtract(b['center_m'], np.multiply(b['size_m'], 0.5)) for b in boxes], axis=0)
    hi = np.max([np.add(b['center_m'], np.multiply(b['size_m'], 0.5)) for b in boxes], axis=0)
    _check_inertia('target.inertia_kg_m2', target['inertia_kg_m2'], target['mass_kg'], float(np.max(hi - lo)),
                   'the largest extent of target.geometry')
    check_grasp_point(target['grasp_point_body_m'], boxes)
    if chaser['inertia_kg_m2'] is not None:
        _check_inertia('chaser.inertia_kg_m2', chaser['inertia_kg_m2'], chaser['mass_kg'],
                       2.0 * chaser['envelope_radius_m'], 'the diameter of chaser.envelope_radius_m')


def plausible_view(scenario):
    """The rules that need the derived initial state (module doc): the chaser starts outside the target's geometry
    by its envelope radius (the hill origin is the target's CoM; skipped when post_capture.start is attached, the
    chaser then holding the target); raise Invalid."""
    pc = scenario.post_capture
    if pc is not None and pc.start == 'attached':
        return
    boxes = scenario.boxes
    p_body = scenario.rotation_hill_from_body0.inv().apply(np.array(scenario.chaser.initial_position_hill_m, float))
    outside = np.maximum(np.abs(p_body - boxes.center_body_m) - 0.5 * boxes.size_m, 0.0)
    gaps = np.linalg.norm(outside, axis=1)
    i = int(np.argmin(gaps))
    envelope = scenario.chaser.envelope_radius_m
    if gaps[i] <= envelope:
        raise Invalid('chaser.initial_position_hill_m',
                      f'the chaser must start outside the target\'s geometry by more than chaser.envelope_radius_m '
                      f'= {envelope!r} (the run would start in collision), got {gaps[i]:.6g} m from box '
                      f'{boxes.names[i]!r}')


def _check_orbit(orbit):
    """The orbit radius above the Earth's equatorial radius and below MAX_ORBIT_RADIUS_M; mu within
    MU_RANGE_M3_S2."""
    key, radius = ('orbit.radius_m', orbit['radius_m']) if orbit.get('radius_m') is not None else \
        ('orbit.altitude_m', EARTH_RADIUS_M + orbit['altitude_m'])
    if not EARTH_RADIUS_M < radius <= MAX_ORBIT_RADIUS_M:
        raise Invalid(key, f'the orbit radius must be above the Earth\'s equatorial radius {EARTH_RADIUS_M:g} m and '
                           f'at most {MAX_ORBIT_RADIUS_M:g} m, got {radius!r} m')
    mu = orbit['mu_m3_s2']
    if not MU_RANGE_M3_S2[0] <= mu <= MU_RANGE_M3_S2[1]:
        raise Invalid('orbit.mu_m3_s2', f'must be within [{MU_RANGE_M3_S2[0]:g}, {MU_RANGE_M3_S2[1]:g}] m^3/s^2 (a '
                                        f'moon or a planet; the Earth 3.986e14), got {mu!r}')


def _check_simulation(sim):
    """At least one step and at most MAX_STEPS steps."""
    step, duration = sim['step_s'], sim['duration_s']
    if duration < step:
        raise Invalid('simulation.duration_s', f'must be at least one simulation.step_s = {step!r}, got {duration!r}')
    if duration / step > MAX_STEPS:
        raise Invalid('simulation.duration_s', f'must be at most {MAX_STEPS:g} steps of simulation.step_s = {step!r}, '
                                               f'i.e. <= {MAX_STEPS * step:g} s, got {duration!r}')


def _check_sizes(target, chaser):
    """Geometry boxes within MAX_BOX_M, the envelope radius within ENVELOPE_RANGE_M, the chaser's start farther
    from the target's CoM than its envelope radius (its direction defines the default chaser attitude) and within
    MAX_RANGE_M, its velocity within MAX_SPEED_MPS, its thrusters within THRUSTER_REACH envelope radii of its CoM."""
    for i, box in enumerate(target['geometry']):
        for name in ('size_m', 'center_m'):
            if max(abs(x) for x in box[name]) > MAX_BOX_M:
                raise Invalid(f'target.geometry[{i}].{name}', f'must be within +-{MAX_BOX_M:g} m per axis, got '
                                                              f'{format_floats(box[name])}')
    envelope = chaser['envelope_radius_m']
    if not ENVELOPE_RANGE_M[0] <= envelope <= ENVELOPE_RANGE_M[1]:
        raise Invalid('chaser.envelope_radius_m', f'must be within [{ENVELOPE_RANGE_M[0]:g}, {ENVELOPE_RANGE_M[1]:g}] '
                                                  f'm, got {envelope!r}')
    start = math.hypot(*chaser['initial_position_hill_m'])
    if not envelope < start <= MAX_RANGE_M:
        raise Invalid('chaser.initial_position_hill_m', f'must be farther from the target\'s CoM than '
                                                        f'chaser.envelope_radius_m = {envelope!r} and at most '
                                                        f'{MAX_RANGE_M:g} m, got {start:.6g} m')
    for i, thruster in enumerate(chaser['thrusters']['layout'] or ()):
        if math.hypot(*thruster['position_m']) > THRUSTER_REACH * envelope:
            raise Invalid(f'chaser.thrusters.layout[{i}].position_m',
                          f'must be within {THRUSTER_REACH:g} chaser.envelope_radius_m = '
                          f'{THRUSTER_REACH * envelope:g} m of the CoM, got {format_floats(thruster["position_m"])}')
    speed = math.hypot(*chaser['initial_velocity_hill_mps'])
    if speed > MAX_SPEED_MPS:
        raise Invalid('chaser.initial_velocity_hill_mps', f'must be at most {MAX_SPEED_MPS:g} m/s, got {speed:.6g}')


def _check_rate(key, rate):
    """An initial_rate section's angular velocity at most MAX_RATE_RAD_S, in whichever of its forms it is given."""
    for form, value in rate.items():
        if value is None:
            continue
        rad_s = math.hypot(*value) * (math.pi / 180.0 if form.endswith('deg_s') else 1.0)
        if rad_s > MAX_RATE_RAD_S:
            raise Invalid(f'{key}.{form}', f'must be at most one turn a second ({MAX_RATE_RAD_S:.6g} rad/s), got '
                                           f'{format_floats(value)}')


def _check_mass(key, mass):
    """A mass within MASS_RANGE_KG."""
    if not MASS_RANGE_KG[0] <= mass <= MASS_RANGE_KG[1]:
        raise Invalid(key, f'must be within [{MASS_RANGE_KG[0]:g}, {MASS_RANGE_KG[1]:g}] kg (a CubeSat to twice the '
                           f'ISS), got {mass!r}')


def _check_inertia(key, inertia, mass, extent, what):
    """Principal moments within INERTIA_RANGE times mass extent^2 / 12 (a uniform rod of the body's largest extent:
    a real body's moments lie well inside, a thin shell of that size at most about 8 times it)."""
    moments = np.linalg.eigvalsh(np.asarray(inertia, dtype=float))
    scale = mass * extent ** 2 / 12.0
    lo, hi = INERTIA_RANGE[0] * scale, INERTIA_RANGE[1] * scale
    if not (lo <= moments[0] and moments[-1] <= hi):
        raise Invalid(key, f'principal moments must be within [{lo:.6g}, {hi:.6g}] kg m^2 ({INERTIA_RANGE[0]:g} to '
                           f'{INERTIA_RANGE[1]:g} times mass * L^2 / 12, L = {extent:.6g} m {what}), got '
                           f'{format_floats(moments)}')


def check_grasp_point(point, boxes):
    """The grasp point on the surface of the target's geometry: within GRASP_SURFACE_TOLERANCE_M of a box face and
    no deeper than that inside any box (not at the CoM, not inside the bus, not off every surface)."""
    p = np.asarray(point, dtype=float)
    signed = []
    for b in boxes:
        q = np.abs(p - np.asarray(b['center_m'], dtype=float)) - 0.5 * np.asarray(b['size_m'], dtype=float)
        outside = math.hypot(*np.maximum(q, 0.0))
        signed.append(outside if outside > 0.0 else float(np.max(q)))  # < 0 inside: minus the depth
    i = int(np.argmin(signed))
    tol = GRASP_SURFACE_TOLERANCE_M
    if signed[i] < -tol:
        raise Invalid('target.grasp_point_body_m', f'must lie on the surface of target.geometry (within {tol:g} m of '
                                                   f'a face), got {format_floats(p)}: {-signed[i]:.6g} m inside box '
                                                   f'{boxes[i]["name"]!r} (target.geometry[{i}])')
    if signed[i] > tol:
        raise Invalid('target.grasp_point_body_m', f'must lie on the surface of target.geometry (within {tol:g} m of '
                                                   f'a face), got {format_floats(p)}: {signed[i]:.6g} m from the '
                                                   f'nearest box {boxes[i]["name"]!r} (target.geometry[{i}])')
