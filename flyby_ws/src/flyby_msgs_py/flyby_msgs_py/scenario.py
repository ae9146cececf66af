"""Scenario files (DESIGN §6): a declarative schema, a validating loader and a read-only Scenario.

A scenario is one YAML file.  ``SCHEMA`` below names every key with its type, default (or
REQUIRED), validated range and a one-line description; ``docs/scenario.md`` embeds the table that
``schema_markdown()`` renders from it (a test keeps the two identical).  Adding a key is one line
in ``SCHEMA``.

    sc = load_scenario('scenarios/paper_flyby.yaml')
    sc.chaser.thrusters.isp_s          # 220.0, defaults filled in, read-only
    sc.q_hill_from_body0               # unit quaternion (x, y, z, w), scalar last
    sc.omega_body0_rad_s               # inertial angular velocity of the target in body axes

Every problem raises ``ScenarioError`` (a ``ValueError``) whose message is one line naming the file,
the dotted key path and the problem, e.g.
``scenarios/x.yaml: chaser.mass_kg: must be > 0, got -5.0``.

Quaternion convention: scipy / ROS order (x, y, z, w), scalar last. ``q_hill_from_body`` rotates
body components into hill components: ``v_hill = R(q_hill_from_body) @ v_body``.
"""

import copy
import dataclasses
import difflib
import math
import re
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

EARTH_RADIUS_M = 6378137.0  # WGS-84 equatorial radius: orbit.radius_m = EARTH_RADIUS_M + altitude_m
MU_EARTH_M3_S2 = 3.986004418e14  # EGM-96 / WGS-84 gravitational parameter
MAX_STEP_S = 0.05  # truth is published every step and must reach >= 20 Hz (DESIGN §4)


class ScenarioError(ValueError):
    """An invalid scenario. ``str(err)`` is one line: ``<file>: <key.path>: <problem>``.

    Attributes: ``file`` (as given), ``key`` (dotted path, '' for file-level problems), ``problem``.
    """

    def __init__(self, file, key, problem):
        self.file = str(file)
        self.key = key
        self.problem = problem
        super().__init__(f'{self.file}: {key}: {problem}' if key else f'{self.file}: {problem}')


class _Invalid(Exception):
    """Internal: a validation problem at a key path, turned into ScenarioError with the file name."""

    def __init__(self, key, problem):
        super().__init__(key, problem)
        self.key = key
        self.problem = problem


# --------------------------------------------------------------------------------------------------
# Schema building blocks

class _Marker:
    def __init__(self, name):
        self._name = name

    def __repr__(self):
        return self._name


REQUIRED = _Marker('REQUIRED')


@dataclasses.dataclass(frozen=True)
class Range:
    """A numeric interval written as text: '> 0', '>= 0', '<= 5', '(0, 1000]', '[0, 0.5]'."""

    text: str
    lo: float = -math.inf
    hi: float = math.inf
    lo_closed: bool = False
    hi_closed: bool = False

    @classmethod
    def parse(cls, text):
        t = text.strip()
        m = re.fullmatch(r'(>=|>|<=|<)\s*(\S+)', t)
        if m:
            op, x = m.group(1), float(m.group(2))
            if op[0] == '>':
                return cls(t, lo=x, lo_closed=op == '>=')
            return cls(t, hi=x, hi_closed=op == '<=')
        m = re.fullmatch(r'([\[(])\s*([^,\s]+)\s*,\s*([^\])\s]+)\s*([\])])', t)
        if not m:
            raise ValueError(f'bad range text {text!r}')
        return cls(t, lo=float(m.group(2)), hi=float(m.group(3)),
                   lo_closed=m.group(1) == '[', hi_closed=m.group(4) == ']')

    def contains(self, x):
        lo_ok = x >= self.lo if self.lo_closed else x > self.lo
        hi_ok = x <= self.hi if self.hi_closed else x < self.hi
        return lo_ok and hi_ok

    def describe(self):
        return self.text if self.text[0] in '<>' else f'in {self.text}'


# Field kinds.
FLOAT, INT, STR, BOOL, VEC3, QUAT, MAT3, ENUM = (
    'float', 'int', 'str', 'bool', '3-vector', 'quaternion', '3x3 matrix', 'enum')

# Units derived from the key's suffix (units live in the names, STYLE.md); longest suffix first.
_UNIT_SUFFIXES = (
    ('_m3_s2', 'm^3/s^2'), ('_kg_m2', 'kg m^2'), ('_deg_s', 'deg/s'), ('_rad_s', 'rad/s'),
    ('_mps', 'm/s'), ('_deg', 'deg'), ('_rad', 'rad'), ('_kg', 'kg'), ('_hz', 'Hz'),
    ('_ns', 'N s'), ('_n', 'N'), ('_s', 's'), ('_m', 'm'),
)


def _unit_of(name):
    for suffix, unit in _UNIT_SUFFIXES:
        if name.endswith(suffix):
            return unit
    return ''


@dataclasses.dataclass(frozen=True)
class Field:
    """One leaf key. ``range`` applies to every component of a vector; ``check(value)`` returns a
    problem string or None (for constraints a range cannot say); ``why`` is appended to a range
    violation message."""

    kind: str
    default: object = REQUIRED
    range: str = None
    desc: str = ''
    choices: tuple = ()
    check: object = None
    why: str = ''

    def __post_init__(self):
        if self.range is not None:
            object.__setattr__(self, '_range', Range.parse(self.range))
        else:
            object.__setattr__(self, '_range', None)


@dataclasses.dataclass(frozen=True)
class Section:
    """A mapping of keys. Each tuple in ``one_of`` names keys of which exactly one must be given;
    those keys are neither required nor defaulted individually."""

    fields: dict
    desc: str = ''
    one_of: tuple = ()

    @property
    def alternatives(self):
        return {k for group in self.one_of for k in group}

    @property
    def required(self):
        if self.one_of:
            return True
        alt = self.alternatives
        return any(_is_required(node) for k, node in self.fields.items() if k not in alt)


@dataclasses.dataclass(frozen=True)
class ListOf:
    """A non-empty list of mappings (``item``); ``check(list)`` returns (index, key, problem) or None."""

    item: Section
    desc: str = ''
    min_len: int = 1
    check: object = None


def _is_required(node):
    if isinstance(node, Field):
        return node.default is REQUIRED
    if isinstance(node, Section):
        return node.required
    return True  # ListOf


# --------------------------------------------------------------------------------------------------
# Checks that a range cannot express

def _check_inertia(m):
    a = np.asarray(m, dtype=float)
    scale = np.max(np.abs(a))
    for i, j in ((0, 1), (0, 2), (1, 2)):
        if abs(a[i, j] - a[j, i]) > 1e-9 * scale:
            return f'must be symmetric, got [{i}][{j}] = {a[i, j]!r} but [{j}][{i}] = {a[j, i]!r}'
    moments = np.linalg.eigvalsh(0.5 * (a + a.T))
    if moments[0] <= 0.0:
        return f'must be positive definite, got principal moments {_fmt_list(moments)}'
    if moments[0] + moments[1] < moments[2] * (1.0 - 1e-12):
        return (f'principal moments {_fmt_list(moments)} violate the triangle inequality '
                f'(I1 + I2 >= I3 for any rigid body)')
    return None


def _check_nonzero(v):
    if not any(v):
        return 'must be nonzero, got [0.0, 0.0, 0.0]' if len(v) == 3 else f'must be nonzero, got {v}'
    return None


def _check_unique_names(items):
    seen = {}
    for i, item in enumerate(items):
        if item['name'] in seen:
            return i, 'name', f'duplicate box name {item["name"]!r} (also at index {seen[item["name"]]})'
        seen[item['name']] = i
    return None


def _check_nonempty(s):
    return 'must not be empty' if not s.strip() else None


# --------------------------------------------------------------------------------------------------
# THE SCHEMA. One line per key.

_VEC0 = (0.0, 0.0, 0.0)

SCHEMA = Section(desc='A flyby scenario', fields={
    'name': Field(STR, REQUIRED, desc='Short identifier of the scenario.', check=_check_nonempty),
    'description': Field(STR, '', desc='Free text.'),
    'seed': Field(INT, REQUIRED, '>= 0', 'Seed of every random generator of the run.'),

    'orbit': Section(desc='Circular orbit of the target', one_of=(('radius_m', 'altitude_m'),), fields={
        'radius_m': Field(FLOAT, REQUIRED, '> 0', 'Orbit radius (give this or altitude_m).'),
        'altitude_m': Field(FLOAT, REQUIRED, '> 0',
                            f'Altitude above the equatorial radius {EARTH_RADIUS_M} m (give this or radius_m).'),
        'mu_m3_s2': Field(FLOAT, MU_EARTH_M3_S2, '> 0', 'Gravitational parameter of the central body.'),
    }),

    'target': Section(desc='The tumbling satellite', fields={
        'mass_kg': Field(FLOAT, REQUIRED, '> 0', 'Target mass.'),
        'inertia_kg_m2': Field(MAT3, REQUIRED, None,
                               'Inertia about the CoM in body axes; symmetric positive definite, '
                               'principal moments satisfy the triangle inequality.',
                               check=_check_inertia),
        'initial_attitude': Section(
            desc='Attitude of target_body in hill at t = 0',
            one_of=(('q_hill_from_body', 'rpy_rad', 'body_axis_along_hill'),), fields={
                'q_hill_from_body': Field(QUAT, REQUIRED, None,
                                          'Quaternion [x, y, z, w] taking body to hill components; '
                                          'normalized on load, must be nonzero.', check=_check_nonzero),
                'rpy_rad': Field(VEC3, REQUIRED, None,
                                 '[roll, pitch, yaw]: R_hill_from_body = Rz(yaw) Ry(pitch) Rx(roll).'),
                'body_axis_along_hill': Section(
                    desc='The minimal rotation taking the body axis onto the hill direction', fields={
                        'body': Field(VEC3, REQUIRED, None, 'A body-frame direction (nonzero).',
                                      check=_check_nonzero),
                        'hill': Field(VEC3, REQUIRED, None, 'The hill-frame direction it points along (nonzero).',
                                      check=_check_nonzero),
                    }),
            }),
        'initial_rate': Section(
            desc='Inertial angular velocity of the target at t = 0, in body or in hill axes',
            one_of=(('omega_body_deg_s', 'omega_body_rad_s', 'omega_hill_deg_s', 'omega_hill_rad_s'),),
            fields={
                'omega_body_deg_s': Field(VEC3, REQUIRED, None, 'In target_body axes.'),
                'omega_body_rad_s': Field(VEC3, REQUIRED, None, 'In target_body axes.'),
                'omega_hill_deg_s': Field(VEC3, REQUIRED, None, 'In hill axes at t = 0.'),
                'omega_hill_rad_s': Field(VEC3, REQUIRED, None, 'In hill axes at t = 0.'),
            }),
        'geometry': ListOf(
            desc='Body-frame boxes making up the target shape (keep-out, markers)',
            check=_check_unique_names,
            item=Section(desc='One box', fields={
                'name': Field(STR, REQUIRED, None, 'Unique box name (marker namespace).', check=_check_nonempty),
                'center_m': Field(VEC3, REQUIRED, None, 'Box centre in target_body.'),
                'size_m': Field(VEC3, REQUIRED, '> 0', 'Edge lengths along body x, y, z.'),
            })),
        'grasp_point_body_m': Field(VEC3, REQUIRED, None, 'Grasp point in target_body.'),
    }),

    'chaser': Section(desc='The servicing robot', fields={
        'mass_kg': Field(FLOAT, REQUIRED, '> 0', 'Chaser wet mass at t = 0.'),
        'envelope_radius_m': Field(FLOAT, REQUIRED, '> 0', 'Radius of the sphere enclosing the chaser.'),
        'initial_position_hill_m': Field(VEC3, REQUIRED, None, 'Chaser CoM in hill at t = 0.'),
        'initial_velocity_hill_mps': Field(VEC3, _VEC0, None,
                                           'Chaser velocity relative to the rotating hill frame at t = 0.'),
        'thrusters': Section(desc='Impulsive thrusters', fields={
            'max_thrust_n': Field(FLOAT, REQUIRED, '> 0', 'Maximum thrust along any direction.'),
            'isp_s': Field(FLOAT, REQUIRED, '> 0', 'Specific impulse (fuel use).'),
            'min_impulse_bit_ns': Field(FLOAT, 0.0, '>= 0', 'Smallest impulse the thrusters can give.'),
            'max_delta_v_per_maneuver_mps': Field(FLOAT, REQUIRED, '> 0', 'Largest single delta-v.'),
            'magnitude_error_sigma': Field(FLOAT, 0.0, '[0, 0.5]', 'Relative 1-sigma error of the delta-v magnitude.'),
            'direction_error_sigma_deg': Field(FLOAT, 0.0, '[0, 30]', '1-sigma pointing error of the delta-v.'),
        }),
        'manipulator': Section(desc='Capture arm', fields={
            'reach_m': Field(FLOAT, REQUIRED, '> 0', 'Reach from the chaser CoM.'),
            'position_tolerance_m': Field(FLOAT, REQUIRED, '> 0', 'Largest grasp position error that captures.'),
            'velocity_tolerance_mps': Field(FLOAT, REQUIRED, '> 0', 'Largest grasp velocity error that captures.'),
        }),
    }),

    'sensors': Section(desc='Measurement models', fields={
        'relative_position': Section(desc='Chaser position in hill', fields={
            'rate_hz': Field(FLOAT, 10.0, '(0, 1000]', 'Sample rate (<= 1/simulation.step_s).'),
            'noise_sigma_m': Field(FLOAT, 0.01, '>= 0', '1-sigma white noise per axis.'),
        }),
        'target_attitude': Section(desc='Vision attitude of the target', fields={
            'rate_hz': Field(FLOAT, 10.0, '(0, 1000]', 'Sample rate (<= 1/simulation.step_s).'),
            'noise_sigma_deg': Field(FLOAT, 1.0, '[0, 180]', '1-sigma rotation-angle noise per axis.'),
        }),
    }),

    'estimation': Section(desc='Target motion estimation and chaser relative navigation', fields={
        'gate_probability': Field(FLOAT, 0.9999, '(0, 1)', 'Chi-square(3) probability of the innovation gate of both filters.'),
        'convergence_attitude_3sigma_deg': Field(FLOAT, 1.0, '> 0', 'Target estimate converged when its 3-sigma attitude bound is below this.'),
        'convergence_rate_3sigma_deg_s': Field(FLOAT, 0.05, '> 0', '... and its 3-sigma rate bound below this.'),
        'spin_rate_deg_s': Field(FLOAT, 18.0, '> 0', 'Category IV (spinning) at and above this inertial rate (20 s period).'),
        'hill_fixed_rate_deg_s': Field(FLOAT, 0.1, '> 0', 'Rate relative to hill below which the attitude counts as held in hill (I, II).'),
        'inertial_hold_rate_deg_s': Field(FLOAT, 0.01, '> 0', 'Inertial rate below which the target counts as held in inertial space (I).'),
        'controlled_rate_deg_s': Field(FLOAT, 0.01, '> 0', 'Hill-relative rate below which a hill-held target is three-axis controlled (I), not librating (II).'),
        'controlled_excursion_deg': Field(FLOAT, 2.0, '> 0', 'Largest attitude excursion in hill for category I.'),
        'initial_rate_sigma_deg_s': Field(FLOAT, 20.0, '> 0', 'Prior 1-sigma per axis of the unknown target rate.'),
        'torque_psd_n2m2s': Field(FLOAT, 1e-10, '>= 0', 'Torque-noise spectral density of the target filter per body axis.'),
        'accel_psd_m2_s3': Field(FLOAT, 1e-9, '>= 0', 'White-acceleration spectral density of the chaser navigation filter.'),
        'initial_velocity_sigma_mps': Field(FLOAT, 0.1, '> 0', 'Prior 1-sigma per axis of the chaser velocity.'),
        'injected_rate_error_deg_s': Field(VEC3, _VEC0, None, 'Fault injection: added to the published target body rate (body axes).'),
    }),

    'planner': Section(desc='Capture planning (seed 000 section 4); condition (a) uses estimation.spin_rate_deg_s', fields={
        'offset_m': Field(FLOAT, 1.0, '> 0', 'Offset delta r of the fly-by target point from the grasp point.'),
        'flyby_duration_s': Field(FLOAT, 300.0, '> 0', 'Time from the fly-by initial point to the grasp.'),
        'restriction_sphere_radius_m': Field(FLOAT, 15.0, '> 0', 'No thrusting inside this sphere about the target.'),
        'clearance_margin_m': Field(FLOAT, 0.1, '>= 0', 'Least gap between the chaser envelope and the swept keep-out region on the passive path.'),
        'escape_check_orbits': Field(FLOAT, 1.0, '>= 1', 'Length of the passive escape checked after the grasp, in orbits.'),
        'min_spin_axis_angle_from_orbit_normal_deg': Field(FLOAT, 10.0, '[0, 90)', 'Condition (b): spin axis at least this far from hill y (no pure out-of-plane motion).'),
        'sun_direction_hill': Field(VEC3, None, None, 'Condition (c): sun direction in hill at t = 0 (inertially fixed); omitted: lighting not checked.', check=_check_nonzero),
        'max_sun_angle_from_grasp_velocity_deg': Field(FLOAT, 100.0, '(0, 180]', 'Condition (c): angle between the grasp velocity and the sun at most this.'),
        'min_observation_s': Field(FLOAT, 60.0, '>= 0', 'Plan no earlier than this after the first target measurement (and with a converged estimate).'),
        'maneuver_lead_s': Field(FLOAT, 10.0, '> 0', 'Time from the plan to the first terminal-approach burn.'),
        'transfer_min_s': Field(FLOAT, 150.0, '> 0', 'Shortest terminal transfer (first burn to the fly-by initial point).'),
        'transfer_max_s': Field(FLOAT, 450.0, '> 0', 'Longest terminal transfer; with transfer_min_s it sets the grasp-time search window.'),
        'delta_v_tie_mps': Field(FLOAT, 0.001, '>= 0', 'Plans within this total delta-v of the cheapest tie; the larger clearance wins.'),
    }),

    'guidance': Section(desc='Terminal approach and trajectory adjusting', fields={
        'adjust_interval_s': Field(FLOAT, 20.0, '> 0', 'Cadence of trajectory-adjusting maneuvers.'),
        'midcourse_corrections': Field(INT, 1, '>= 0', 'CW re-solves (eq 28) spread evenly over the terminal transfer.'),
        'command_lead_s': Field(FLOAT, 5.0, '> 0', 'A burn is computed from the latest estimate and sent this long before it starts.'),
        'deadband_mps': Field(FLOAT, 0.0002, '>= 0', 'Adjusting burns smaller than this (or the minimum impulse bit) are skipped.'),
        'adjust_position_tolerance_m': Field(FLOAT, 0.005, '> 0', 'Predicted miss at the fly-by target point small enough to stop adjusting ...'),
        'adjust_velocity_tolerance_mps': Field(FLOAT, 0.0005, '> 0', '... together with this velocity miss.'),
        'sphere_margin_m': Field(FLOAT, 1.0, '>= 0', 'No burn whose predicted arc comes within this of the restriction sphere.'),
        'refine_target': Field(BOOL, True, None, 'Re-aim each adjusting burn at the grasp re-solved from the latest target estimate.'),
    }),

    'supervisor': Section(desc='Mission phases, capture decision, watchdog and abort', fields={
        'capture_hold_s': Field(FLOAT, 10.0, '>= 0', 'Time attached to the target before COMPLETE.'),
        'watchdog_s': Field(FLOAT, 5.0, '> 0', 'Abort and escape when the estimator or guidance has been silent this long (sim time).'),
        'abort_observation_s': Field(FLOAT, 60.0, '>= 0', 'The run goes on this long after ABORTED, to record the escape.'),
        'avoidance_delta_v_mps': Field(FLOAT, 0.05, '> 0', 'Size of the collision-avoidance burn an abort outside the restriction sphere may fire.'),
    }),

    'simulation': Section(desc='Plant integration', fields={
        'dynamics': Field(ENUM, 'nonlinear', None, 'Relative orbital dynamics: nonlinear two-body or linear CW.',
                          choices=('cw', 'nonlinear')),
        'step_s': Field(FLOAT, MAX_STEP_S, f'(0, {MAX_STEP_S}]',
                        'Fixed integration step; truth is published every step.',
                        why=f'truth is published every step and must reach >= {1 / MAX_STEP_S:g} Hz, DESIGN §4'),
        'duration_s': Field(FLOAT, REQUIRED, '> 0', 'Simulated time after which the run stops.'),
    }),
})


def _cross_checks(d):
    """Checks across keys, on the resolved dict; raise _Invalid."""
    step = d['simulation']['step_s']
    for sensor in ('relative_position', 'target_attitude'):
        rate = d['sensors'][sensor]['rate_hz']
        if rate * step > 1.0 + 1e-9:
            raise _Invalid(f'sensors.{sensor}.rate_hz',
                           f'must be <= 1/simulation.step_s = {1.0 / step:g} Hz (a sensor samples at most '
                           f'once per step), got {rate!r}')
    planner = d['planner']
    if planner['transfer_max_s'] < planner['transfer_min_s']:
        raise _Invalid('planner.transfer_max_s', f"must be >= planner.transfer_min_s = {planner['transfer_min_s']!r}, "
                                                 f"got {planner['transfer_max_s']!r}")


# --------------------------------------------------------------------------------------------------
# Validation

def _describe(v):
    if v is None:
        return 'null'
    if isinstance(v, (bool, np.bool_)):
        return 'true (bool)' if v else 'false (bool)'
    if isinstance(v, str):
        return f'string {v!r}'
    if isinstance(v, dict):
        return 'a mapping'
    if isinstance(v, (list, tuple)):
        return f'a list of length {len(v)}'
    if isinstance(v, np.ndarray):
        return f'an array of shape {v.shape}'
    return repr(v)


def _fmt_list(a):
    return '[' + ', '.join(repr(float(x)) for x in a) + ']'


def _is_number(v):
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))


def _number(v, key, field):
    if not _is_number(v):
        raise _Invalid(key, f'must be a number, got {_describe(v)}')
    x = float(v)
    if not math.isfinite(x):
        raise _Invalid(key, f'must be finite, got {x!r}')
    r = field._range
    if r is not None and not r.contains(x):
        why = f' ({field.why})' if field.why else ''
        raise _Invalid(key, f'must be {r.describe()}, got {x!r}{why}')
    return x


def _sequence(v):
    if isinstance(v, np.ndarray):
        return v.tolist() if v.ndim >= 1 else None
    return list(v) if isinstance(v, (list, tuple)) else None


def _vector(v, n, key, field, what):
    seq = _sequence(v)
    if seq is None:
        raise _Invalid(key, f'must be {what}, got {_describe(v)}')
    if len(seq) != n:
        raise _Invalid(key, f'must be {what}, got a list of length {len(seq)}')
    return [_number(x, f'{key}[{i}]', field) for i, x in enumerate(seq)]


def _leaf(field, v, key):
    kind = field.kind
    if kind == FLOAT:
        out = _number(v, key, field)
    elif kind == INT:
        if not isinstance(v, (int, np.integer)) or isinstance(v, (bool, np.bool_)):
            raise _Invalid(key, f'must be an integer, got {_describe(v)}')
        out = int(v)
        r = field._range
        if r is not None and not r.contains(out):
            raise _Invalid(key, f'must be {r.describe()}, got {out}')
    elif kind == STR:
        if not isinstance(v, str):
            raise _Invalid(key, f'must be a string, got {_describe(v)}')
        out = v
    elif kind == BOOL:
        if not isinstance(v, (bool, np.bool_)):
            raise _Invalid(key, f'must be true or false, got {_describe(v)}')
        out = bool(v)
    elif kind == ENUM:
        if v not in field.choices or not isinstance(v, str):
            choices = '[' + ', '.join(repr(c) for c in field.choices) + ']'
            raise _Invalid(key, f'must be one of {choices}, got {v!r}')
        out = v
    elif kind == VEC3:
        out = _vector(v, 3, key, field, 'a 3-vector [x, y, z]')
    elif kind == QUAT:
        out = _vector(v, 4, key, field, 'a quaternion [x, y, z, w]')
    elif kind == MAT3:
        rows = _sequence(v)
        what = 'a 3x3 matrix (a list of 3 rows of 3 numbers)'
        if rows is None or len(rows) != 3:
            raise _Invalid(key, f'must be {what}, got {_describe(v)}')
        out = [_vector(row, 3, f'{key}[{i}]', field, 'a row of 3 numbers') for i, row in enumerate(rows)]
    else:  # pragma: no cover - schema bug
        raise AssertionError(kind)
    if field.check is not None:
        problem = field.check(out)
        if problem:
            raise _Invalid(key, problem)
    return out


def _join(prefix, key):
    return f'{prefix}.{key}' if prefix else key


def _section(section, v, prefix):
    if v is None and prefix:
        v = {}  # a section whose keys are all commented out
    if not isinstance(v, dict):
        if not prefix:
            raise _Invalid('', f'top level must be a mapping of sections, got {_describe(v)}')
        raise _Invalid(prefix, f'must be a mapping, got {_describe(v)}')
    allowed = list(section.fields)
    for k in v:
        if not isinstance(k, str) or k not in section.fields:
            hint = difflib.get_close_matches(str(k), allowed, n=1, cutoff=0.6)
            msg = f"unknown key (did you mean '{hint[0]}'?)" if hint else \
                f'unknown key (expected one of: {", ".join(allowed)})'
            raise _Invalid(_join(prefix, str(k)), msg)
    for group in section.one_of:
        given = [k for k in group if k in v]
        if len(given) != 1:
            names = ', '.join(repr(k) for k in group)
            got = 'none' if not given else ', '.join(repr(k) for k in given)
            raise _Invalid(prefix, f'exactly one of {names} must be given, got {got}')
    alternatives = section.alternatives
    out = {}
    for k, node in section.fields.items():
        key = _join(prefix, k)
        if k not in v:
            if k in alternatives:
                continue
            if isinstance(node, Section) and not node.required:
                out[k] = _section(node, {}, key)
                continue
            if _is_required(node):
                raise _Invalid(key, 'missing required key')
            out[k] = copy.deepcopy(list(node.default) if isinstance(node.default, tuple) else node.default)
            continue
        out[k] = _node(node, v[k], key)
    return out


def _node(node, v, key):
    if isinstance(node, Section):
        return _section(node, v, key)
    if isinstance(node, ListOf):
        if not isinstance(v, (list, tuple)) or len(v) < node.min_len:
            raise _Invalid(key, f'must be a non-empty list, got {_describe(v)}')
        items = []
        for i, item in enumerate(v):
            if not isinstance(item, dict):
                raise _Invalid(f'{key}[{i}]', f'must be a mapping, got {_describe(item)}')
            items.append(_section(node.item, item, f'{key}[{i}]'))
        if node.check is not None:
            bad = node.check(items)
            if bad:
                i, k, problem = bad
                raise _Invalid(f'{key}[{i}].{k}', problem)
        return items
    if v is None and node.default is None:  # an optional key written out as null
        return None
    return _leaf(node, v, key)


def validate(data, seed=None):
    """Validate a parsed scenario mapping; return the resolved dict (defaults filled in).

    Raises ``_Invalid``; use ``load_scenario`` or ``scenario_from_dict`` for ScenarioError.
    """
    resolved = _section(SCHEMA, data, '')
    if seed is not None:
        try:
            resolved['seed'] = _leaf(SCHEMA.fields['seed'], seed, 'seed')
        except _Invalid as e:
            raise _Invalid('seed', f'{e.problem} (from the seed argument)') from None
    _cross_checks(resolved)
    return resolved


# --------------------------------------------------------------------------------------------------
# YAML

class _Loader(yaml.SafeLoader):
    """SafeLoader that rejects duplicate keys and reads YAML 1.2 floats without a dot (``1e5``)."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            self.flatten_mapping(node)
            seen = set()
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=deep)
                try:
                    duplicate = key in seen
                    seen.add(key)
                except TypeError:
                    continue  # unhashable key: the base class reports it
                if duplicate:
                    raise yaml.constructor.ConstructorError(
                        None, None, f'duplicate key {key!r}', key_node.start_mark)
        return super().construct_mapping(node, deep=deep)


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _Loader.construct_mapping)
_Loader.add_implicit_resolver(
    'tag:yaml.org,2002:float', re.compile(r'^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+$'),
    list('-+0123456789'))


def _parse_yaml(text, file):
    try:
        return yaml.load(text, Loader=_Loader)  # noqa: S506 - a SafeLoader subclass
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark or e.context_mark
        where = f' at line {mark.line + 1}, column {mark.column + 1}' if mark else ''
        problem = str(e.problem or e.context)
        if e.context and e.problem:
            cm = e.context_mark
            started = f' that starts at line {cm.line + 1}, column {cm.column + 1}' \
                if cm is not None and cm is not mark and cm.line != mark.line else ''
            problem += f' ({e.context}{started})'
        kind = 'YAML error' if isinstance(e, yaml.constructor.ConstructorError) else 'YAML syntax error'
        raise ScenarioError(file, '', f'{kind}{where}: {problem}') from None
    except yaml.YAMLError as e:
        raise ScenarioError(file, '', f'YAML error: {" ".join(str(e).split())}') from None


# --------------------------------------------------------------------------------------------------
# The read-only result

class Namespace:
    """Read-only attribute view of a resolved section: ``ns.key``, ``ns['key']``, ``'key' in ns``.

    Vectors and matrices are read-only float arrays; lists of mappings are tuples of Namespaces; an
    alternative that was not given (e.g. ``orbit.altitude_m`` when ``radius_m`` is) reads as None.
    """

    __slots__ = ('_key', '_values', '_schema')

    def __init__(self, values, key='', schema=None):
        object.__setattr__(self, '_key', key)
        object.__setattr__(self, '_schema', schema)
        object.__setattr__(self, '_values', {k: _freeze(v, _join(key, k)) for k, v in values.items()})

    def __getattr__(self, name):
        values = object.__getattribute__(self, '_values')
        if name in values:
            return values[name]
        schema = object.__getattribute__(self, '_schema')
        if schema is not None and name in schema.fields:
            return None  # an alternative that was not given
        where = object.__getattribute__(self, '_key') or 'scenario'
        raise AttributeError(f'{where} has no key {name!r}')

    def __setattr__(self, name, value):
        raise AttributeError('scenario values are read-only')

    def __delattr__(self, name):
        raise AttributeError('scenario values are read-only')

    def __getitem__(self, name):
        return self._values[name]

    def __contains__(self, name):
        return name in self._values

    def __iter__(self):
        return iter(self._values)

    def keys(self):
        return self._values.keys()

    def to_dict(self):
        return {k: _thaw(v) for k, v in self._values.items()}

    def __eq__(self, other):
        return isinstance(other, Namespace) and self.to_dict() == other.to_dict()

    def __reduce__(self):  # pickle / deepcopy (Monte Carlo workers)
        return _namespace, (self.to_dict(), self._key)

    __hash__ = None

    def __repr__(self):
        return f'Namespace({self._key or "scenario"}: {", ".join(self._values)})'


def _namespace(values, key):
    return Namespace(values, key, _schema_at(re.sub(r'\[\d+\]', '', key)))


def _schema_at(key):
    if not key:
        return SCHEMA
    node = SCHEMA
    for part in key.split('.'):
        part = re.sub(r'\[\d+\]$', '', part)
        node = node.fields[part]
        if isinstance(node, ListOf):
            node = node.item
    return node if isinstance(node, Section) else None


def _freeze(v, key):
    if isinstance(v, dict):
        return Namespace(v, key, _schema_at(re.sub(r'\[\d+\]', '', key)))
    if isinstance(v, list):
        if v and isinstance(v[0], dict):
            return tuple(_freeze(x, f'{key}[{i}]') for i, x in enumerate(v))
        a = np.array(v, dtype=float)
        a.flags.writeable = False
        return a
    return v


def _thaw(v):
    if isinstance(v, Namespace):
        return v.to_dict()
    if isinstance(v, tuple):
        return [_thaw(x) for x in v]
    if isinstance(v, np.ndarray):
        return v.tolist()
    return v


class Boxes:
    """The target geometry as arrays: ``names`` (tuple of str), ``center_body_m`` (N, 3), ``size_m`` (N, 3)."""

    __slots__ = ('names', 'center_body_m', 'size_m')

    def __init__(self, names, center_body_m, size_m):
        self.names = names
        self.center_body_m = center_body_m
        self.size_m = size_m

    def __len__(self):
        return len(self.names)

    def __repr__(self):
        return f'Boxes({list(self.names)})'


def _minimal_rotation(body, hill):
    """The smallest rotation R with R @ body/|body| = hill/|hill| (a half turn if they are opposite)."""
    b = np.asarray(body, dtype=float) / np.linalg.norm(body)
    h = np.asarray(hill, dtype=float) / np.linalg.norm(hill)
    axis = np.cross(b, h)
    s, c = np.linalg.norm(axis), float(np.dot(b, h))
    if s < 1e-12:
        if c > 0.0:
            return Rotation.identity()
        # Opposite: turn by pi about the axis perpendicular to b nearest the least-aligned basis vector.
        axis = np.cross(b, np.eye(3)[int(np.argmin(np.abs(b)))])
        return Rotation.from_rotvec(math.pi * axis / np.linalg.norm(axis))
    return Rotation.from_rotvec(axis / s * math.atan2(s, c))


class Scenario:
    """A validated scenario: read-only sections by attribute (``sc.chaser.thrusters.isp_s``) plus
    derived numpy values. Build it with ``load_scenario`` or ``scenario_from_dict``."""

    def __init__(self, resolved, raw, path=None):
        object.__setattr__(self, '_root', Namespace(resolved, '', SCHEMA))
        object.__setattr__(self, '_raw', raw)
        object.__setattr__(self, 'path', Path(path) if path is not None else None)
        object.__setattr__(self, '_derived', self._derive())

    # -- access -----------------------------------------------------------------------------------
    def __getattr__(self, name):
        return getattr(object.__getattribute__(self, '_root'), name)

    def __setattr__(self, name, value):
        raise AttributeError('a Scenario is read-only')

    def __getitem__(self, name):
        return self._root[name]

    def __eq__(self, other):
        return isinstance(other, Scenario) and self.to_dict() == other.to_dict()

    def __reduce__(self):  # pickle / deepcopy (Monte Carlo workers)
        return Scenario, (self.to_dict(), self._raw, self.path)

    __hash__ = None

    def __repr__(self):
        return f'Scenario({self.name!r}, seed={self.seed}, path={str(self.path) if self.path else None!r})'

    @property
    def raw(self):
        """The parsed YAML mapping exactly as given (a copy)."""
        return copy.deepcopy(self._raw)

    def to_dict(self):
        """Resolved values including defaults, plain Python (YAML-dumpable, loads to an equal Scenario)."""
        return self._root.to_dict()

    def to_yaml(self):
        """``to_dict()`` as YAML text."""
        return yaml.safe_dump(self.to_dict(), sort_keys=False, default_flow_style=None, width=100)

    # -- derived ----------------------------------------------------------------------------------
    def _derive(self):
        t = self._root.target
        att = t.initial_attitude
        if att.q_hill_from_body is not None:
            rot = Rotation.from_quat(np.array(att.q_hill_from_body))  # normalizes
        elif att.rpy_rad is not None:
            roll, pitch, yaw = att.rpy_rad
            rot = Rotation.from_euler('xyz', [roll, pitch, yaw])  # extrinsic x-y-z = Rz(yaw) Ry(pitch) Rx(roll)
        else:
            rot = _minimal_rotation(att.body_axis_along_hill.body, att.body_axis_along_hill.hill)
        rate = t.initial_rate
        if rate.omega_body_rad_s is not None:
            omega_body = np.array(rate.omega_body_rad_s)
        elif rate.omega_body_deg_s is not None:
            omega_body = np.radians(rate.omega_body_deg_s)
        elif rate.omega_hill_rad_s is not None:
            omega_body = rot.inv().apply(np.array(rate.omega_hill_rad_s))  # omega_B = R_BH omega_H
        else:
            omega_body = rot.inv().apply(np.radians(rate.omega_hill_deg_s))
        orbit = self._root.orbit
        radius = orbit.radius_m if orbit.radius_m is not None else EARTH_RADIUS_M + orbit.altitude_m
        return {
            'rotation': rot,
            'q': rot.as_quat(canonical=True),
            'omega_body': np.asarray(omega_body, dtype=float),
            'radius': float(radius),
            'n': math.sqrt(orbit.mu_m3_s2 / radius ** 3),
        }

    @property
    def orbit_radius_m(self):
        """Circular orbit radius [m]: radius_m, or EARTH_RADIUS_M + altitude_m."""
        return self._derived['radius']

    @property
    def mean_motion_rad_s(self):
        """Orbit rate Omega_t = sqrt(mu / r^3) [rad/s]."""
        return self._derived['n']

    @property
    def orbit_period_s(self):
        """2 pi / mean motion [s]."""
        return 2.0 * math.pi / self._derived['n']

    @property
    def target_inertia(self):
        """Target inertia [kg m^2] in body axes, a fresh (3, 3) array."""
        return np.array(self._root.target.inertia_kg_m2)

    @property
    def rotation_hill_from_body0(self):
        """scipy Rotation taking target_body components to hill components at t = 0."""
        return self._derived['rotation']

    @property
    def q_hill_from_body0(self):
        """Unit quaternion (x, y, z, w) of target_body in hill at t = 0, w >= 0; a fresh array."""
        return self._derived['q'].copy()

    @property
    def omega_body0_rad_s(self):
        """Inertial angular velocity of the target in target_body axes at t = 0 [rad/s]; a fresh array."""
        return self._derived['omega_body'].copy()

    @property
    def boxes(self):
        """Target geometry as arrays (``Boxes``: names, center_body_m (N, 3), size_m (N, 3))."""
        g = self._root.target.geometry
        return Boxes(tuple(b.name for b in g), np.array([b.center_m for b in g]), np.array([b.size_m for b in g]))


# --------------------------------------------------------------------------------------------------
# Entry points

def scenario_from_dict(data, name='<dict>', seed=None, path=None):
    """Validate a scenario mapping (as parsed from YAML) into a Scenario; ``name`` labels errors."""
    try:
        resolved = validate(data, seed=seed)
    except _Invalid as e:
        raise ScenarioError(name, e.key, e.problem) from None
    return Scenario(resolved, copy.deepcopy(data), path)


def load_scenario(path, seed=None):
    """Load and validate a scenario YAML file; ``seed`` (int >= 0) overrides the file's seed.

    Raises ScenarioError with a one-line message ``<path>: <key.path>: <problem>``.
    """
    file = str(path)
    try:
        text = Path(path).read_text(encoding='utf-8')
    except FileNotFoundError:
        raise ScenarioError(file, '', 'file not found') from None
    except IsADirectoryError:
        raise ScenarioError(file, '', 'is a directory, not a scenario file') from None
    except UnicodeDecodeError as e:
        raise ScenarioError(file, '', f'not UTF-8 text ({e.reason} at byte {e.start})') from None
    except OSError as e:
        raise ScenarioError(file, '', f'cannot read: {e.strerror}') from None
    data = _parse_yaml(text, file)
    if not isinstance(data, dict):
        got = 'an empty file' if data is None else _describe(data)
        raise ScenarioError(file, '', f'top level must be a mapping of sections, got {got}')
    return scenario_from_dict(data, name=file, seed=seed, path=path)


# --------------------------------------------------------------------------------------------------
# Documentation from the schema

def _fmt_default(node, alternative):
    if alternative:
        return 'one of'
    if isinstance(node, Field):
        d = node.default
        if d is REQUIRED:
            return '**required**'
        if isinstance(d, tuple):
            return '[' + ', '.join(f'{x:g}' for x in d) + ']'
        if isinstance(d, str):
            return f"'{d}'"
        return f'{d:.10g}' if isinstance(d, float) else str(d)
    return '**required**' if _is_required(node) else '(defaults)'


def _fmt_type(node):
    if isinstance(node, ListOf):
        return 'list of mappings'
    if isinstance(node, Section):
        return 'mapping'
    if node.kind == ENUM:
        return ' \\| '.join(f"'{c}'" for c in node.choices)
    return node.kind


def _schema_rows(section, prefix):
    alt = section.alternatives
    for k, node in section.fields.items():
        key = _join(prefix, k)
        if isinstance(node, Field):
            rng = node._range.describe() if node._range is not None else ''
            if node.kind in (VEC3, QUAT, MAT3) and not rng:
                rng = 'finite'
            elif node.kind in (VEC3, QUAT) and rng:
                rng = f'each {rng}'
            yield key, _fmt_type(node), _unit_of(k), _fmt_default(node, k in alt), rng, node.desc
        else:
            note = ''
            if isinstance(node, Section) and node.one_of:
                note = ' Exactly one of ' + '; '.join(', '.join(f'`{x}`' for x in g) for g in node.one_of) + '.'
            yield key, _fmt_type(node), '', _fmt_default(node, k in alt), \
                'non-empty' if isinstance(node, ListOf) else '', node.desc + '.' + note
            inner = node.item if isinstance(node, ListOf) else node
            yield from _schema_rows(inner, f'{key}[]' if isinstance(node, ListOf) else key)


def schema_markdown():
    """The key table of docs/scenario.md, rendered from SCHEMA."""
    lines = ['| key | type | unit | default | range | meaning |', '|---|---|---|---|---|---|']
    for key, kind, unit, default, rng, desc in _schema_rows(SCHEMA, ''):
        lines.append(f'| `{key}` | {kind} | {unit} | {default} | {rng} | {desc} |')
    return '\n'.join(lines) + '\n'


def main(argv=None):
    """``python -m flyby_msgs_py.scenario FILE [--seed N]`` prints the resolved scenario or the error;
    ``--schema-markdown`` prints the key table of docs/scenario.md."""
    import argparse
    import sys
    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument('file', nargs='?')
    parser.add_argument('--seed', type=int)
    parser.add_argument('--schema-markdown', action='store_true')
    args = parser.parse_args(argv)
    if args.schema_markdown:
        sys.stdout.write(schema_markdown())
        return 0
    if not args.file:
        parser.error('a scenario file is required')
    try:
        sc = load_scenario(args.file, seed=args.seed)
    except ScenarioError as e:
        print(e, file=sys.stderr)
        return 2
    sys.stdout.write(sc.to_yaml())
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
