"""Monte Carlo dispersions of scenario keys (docs/campaigns.md), after Basilisk's MonteCarlo ``Dispersions.py``.

A campaign file (YAML) names a base scenario, a campaign seed and the dispersions, one per scenario
key by dotted path (list items by index: ``target.geometry.0.size_m``), drawn in file order::

    name: smoke
    base_scenario: ../scenarios/paper_flyby.yaml   # relative to the campaign file
    overrides: {planner.sun_direction_hill: null}  # fixed values applied to the base (optional)
    seed: 2026                                      # campaign seed
    runs: 20                                        # default number of runs
    dispersions:
      target.initial_rate.omega_body_deg_s: {kind: uniform, low: [0, 0, 3], high: [0, 0, 8]}
      target.initial_attitude.body_axis_along_hill.hill:
        kind: direction
        exclude_cone: {axis: [0, 1, 0], half_angle_deg: 10, both_ways: true}
      sensors.relative_position.noise_sigma_m: {kind: scale, factor: {kind: uniform, low: 0.5, high: 2}}

Kinds (``KINDS``): ``uniform`` (low, high: scalars or one per component, of a vector or a matrix such as
``target.inertia_kg_m2``), ``normal`` (mean, sigma),
``direction`` (uniform on the unit sphere, optional ``exclude_cone`` {axis, half_angle_deg,
both_ways}, optional ``magnitude``: a number or a nested scalar dispersion, optional ``axis_probability``:
the chance of one of +-x, +-y, +-z instead, e.g. a principal spin of a body with diagonal inertia; a 3-vector),
``box_surface_point`` (uniform by area on the faces of the base scenario's target boxes, or of the
boxes named in ``boxes``), ``choice`` (values, optional weights) and ``scale`` (the base value times
``factor``, a number or a nested scalar dispersion).

A ``choice`` alone may name a list (``chaser.thrusters.layout``: each value a whole list) or a section: each value
is then a mapping of keys below it (dotted: ``wheels.max_torque_n_m`` under ``chaser``), set together on the base
section as ``overrides`` are, so one draw sets keys that belong together (a goal and its transfer time, a tug's mass,
inertia and wheels); the keys a value leaves out keep the base's values::

    post_capture.transport:
      kind: choice
      values: [{goal_hill_m: [200, 0, 0], transfer_time_s: 600}, {goal_hill_m: [-2000, 0, 0], transfer_time_s: 1500}]

Run i is drawn from ``np.random.default_rng(np.random.SeedSequence([campaign_seed, i]))`` alone: first
the run's scenario seed, then each dispersion in file order; so any run is redrawn alone, equal to
its draw in the whole campaign. Giving one alternative of a one-of group (``omega_hill_deg_s`` where
the base gave ``omega_body_deg_s``) removes the other alternatives of that group from the drawn scenario.

Every problem raises ``CampaignError`` (a ``ScenarioError``), one line ``<campaign file>: <key>: <problem>``,
before any run starts: unknown kinds, keys or parameters, keys not in the scenario, impossible ranges,
strings or booleans where numbers are due (and the reverse), an excluded cone that leaves (almost) no direction,
and a dispersion whose draws make an invalid scenario: every run is drawn and validated by the scenario loader
at load time (at most ``MAX_RUNS``, about 2 ms each), so no run flies before all of them are known valid.
"""

import copy
import hashlib
import math
from pathlib import Path

import numpy as np

from flyby_msgs_py.schema import (
    MAGNITUDE_RANGE,
    ListOf,
    ScenarioError,
    Section,
    describe,
    load_yaml_mapping,
    short_repr,
)
from flyby_sim.scenario import SCHEMA, SEED_MAX, load_scenario, scenario_from_dict

KINDS = ('uniform', 'normal', 'direction', 'box_surface_point', 'choice', 'scale')
# The parameters each kind takes (besides 'kind'), required ones first.
_PARAMS = {
    'uniform': (('low', 'high'), ()),
    'normal': (('mean', 'sigma'), ()),
    'direction': ((), ('exclude_cone', 'magnitude', 'axis_probability')),
    'box_surface_point': ((), ('boxes',)),
    'choice': (('values',), ('weights',)),
    'scale': (('factor',), ()),
}
_CAMPAIGN_KEYS = {'name', 'description', 'base_scenario', 'overrides', 'seed', 'runs', 'dispersions'}
# Keys the campaign itself sets: the seed comes from the run's stream, the name labels the campaign.
_RESERVED_KEYS = ('seed', 'name')
SCENARIO_SEED_BOUND = 2**31  # run seeds are drawn in [0, 2**31), within the seeds' range [0, SEED_MAX]
MAX_RUNS = 10_000  # runs of one campaign, each drawn and validated (about 2 ms) before the first flies
_MAX_REJECTIONS = 10_000  # draws of a direction outside the excluded cone(s) before giving up
# The excluded cone(s) leave at least this fraction of the sphere, so _MAX_REJECTIONS draws never all fall inside
# (the chance is 0.99 ** 10_000, about 2e-44).
_MIN_DIRECTION_FRACTION = 0.01


class CampaignError(ScenarioError):
    """An invalid campaign file: one line ``<file>: <key>: <problem>`` (key '' for file-level problems)."""


# --------------------------------------------------------------------------------------------------
# Draws of one dispersion

def _only_numbers(v):
    """True when v is a number or (nested) lists of numbers: no string nor boolean that numpy would coerce."""
    if isinstance(v, (list, tuple)):
        return all(_only_numbers(x) for x in v)
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _number_array(v, file, key, what):
    a = None
    if _only_numbers(v):
        try:
            a = np.asarray(v, dtype=float)
        except (TypeError, ValueError, OverflowError):
            pass
    if a is None or a.ndim > 2 or not np.all(np.isfinite(a)) or np.any(np.abs(a) > MAGNITUDE_RANGE[1]):
        raise CampaignError(file, key, f'{what} must be a finite number (at most {MAGNITUDE_RANGE[1]:g} in '
                                       f'magnitude, as every scenario number), a list of them or a matrix (a list of '
                                       f'equal lists, e.g. an inertia) of them, got {short_repr(v)}')
    return a


def _number(v, file, key):
    """A finite real number (not a boolean nor a string) within MAGNITUDE_RANGE, as a float."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not abs(v) <= MAGNITUDE_RANGE[1]:
        raise CampaignError(file, key, f'must be a finite number (at most {MAGNITUDE_RANGE[1]:g} in magnitude), got '
                                       f'{describe(v)}')
    return float(v)


def _short_key(k):
    """A key of the file as text for a message, cut to a line (a key may be any scalar, of any length)."""
    text = str(k)
    return text if len(text) <= 80 else text[:77] + '...'


def _plain(x):
    """numpy scalars, vectors and matrices as plain Python floats and (nested) lists (YAML-dumpable, JSON-writable)."""
    a = np.asarray(x, dtype=float)
    return float(a) if a.ndim == 0 else a.tolist()


def _unit(v, file, key, what):
    a = _number_array(v, file, key, what)
    norm = math.hypot(*a) if a.shape == (3,) else 0.0  # hypot: no overflow of the squares of 1e300
    if norm == 0.0:
        raise CampaignError(file, key, f'{what} must be a nonzero 3-vector, got {short_repr(v)}')
    return a / norm


def _exclude_cone(cone, file, where):
    """(unit axis, cosine of the half angle, both ways) of an ``exclude_cone`` mapping; the cone (or the two
    opposite cones) must leave at least _MIN_DIRECTION_FRACTION of the sphere, else the draws could not end."""
    axis = _unit(cone['axis'], file, f'{where}.axis', 'axis')
    half = _number(cone['half_angle_deg'], file, f'{where}.half_angle_deg')
    both = cone.get('both_ways', False)
    if not isinstance(both, bool):
        raise CampaignError(file, f'{where}.both_ways', f'must be true or false, got {describe(both)}')
    # The fraction of the sphere outside one cone is (1 + cos h) / 2, outside two opposite ones cos h.
    cos_min = _MIN_DIRECTION_FRACTION if both else 2.0 * _MIN_DIRECTION_FRACTION - 1.0
    max_half = math.degrees(math.acos(cos_min))
    if not 0.0 <= half <= max_half:
        cones = 'two opposite cones' if both else 'the cone'
        raise CampaignError(file, f'{where}.half_angle_deg',
                            f'must be in [0, {max_half:.2f}] ({cones} must leave at least '
                            f'{_MIN_DIRECTION_FRACTION:.0%} of the directions), got {half!r}')
    return axis, math.cos(math.radians(half)), both


class Dispersion:
    """One dispersion: ``key`` (dotted scenario path), ``kind``, and ``draw(rng, base_value)``, the
    drawn value as plain Python (float, list of floats, or one of ``choice``'s values)."""

    def __init__(self, key, spec, file, boxes=None, base_value=None, nested=False):
        self.key = key
        self.spec = spec
        where = f'dispersions.{key}'
        if isinstance(spec, (int, float)) and not isinstance(spec, bool) and nested:
            self.kind, self._constant = 'constant', float(spec)
            return
        if not isinstance(spec, dict) or 'kind' not in spec:
            raise CampaignError(file, where, f"must be a mapping with a 'kind' (one of {list(KINDS)}), "
                                             f'got {short_repr(spec)}')
        self.kind = spec['kind']
        if not isinstance(self.kind, str) or self.kind not in KINDS:
            raise CampaignError(file, f'{where}.kind', f'unknown dispersion kind {short_repr(self.kind)}, '
                                                       f'one of {list(KINDS)}')
        required, optional = _PARAMS[self.kind]
        for p in required:
            if p not in spec:
                raise CampaignError(file, where, f'{self.kind} needs {p!r}')
        for p in spec:
            if p != 'kind' and p not in required + optional:
                raise CampaignError(file, f'{where}.{_short_key(p)}', f'unknown parameter of {self.kind}, '
                                                          f'it takes {list(required + optional)}')
        getattr(self, f'_init_{self.kind}')(spec, file, where, boxes, base_value)

    # -- parameters, checked once -----------------------------------------------------------------
    def _init_uniform(self, spec, file, where, boxes, base_value):
        self._low = _number_array(spec['low'], file, f'{where}.low', 'low')
        self._high = _number_array(spec['high'], file, f'{where}.high', 'high')
        self._shape = self._broadcast(file, where, base_value, self._low, self._high)
        if np.any(self._low > self._high):
            raise CampaignError(file, where, f'low > high: low {short_repr(spec["low"])}, '
                                             f'high {short_repr(spec["high"])}')

    def _init_normal(self, spec, file, where, boxes, base_value):
        self._mean = _number_array(spec['mean'], file, f'{where}.mean', 'mean')
        self._sigma = _number_array(spec['sigma'], file, f'{where}.sigma', 'sigma')
        if np.any(self._sigma < 0.0):
            raise CampaignError(file, f'{where}.sigma', f'must be >= 0, got {short_repr(spec["sigma"])}')
        self._shape = self._broadcast(file, where, base_value, self._mean, self._sigma)

    def _init_direction(self, spec, file, where, boxes, base_value):
        self._cone = None
        cone = spec.get('exclude_cone')
        if cone is not None:
            unknown = set(cone) - {'axis', 'half_angle_deg', 'both_ways'} if isinstance(cone, dict) else None
            if unknown is None or unknown or not {'axis', 'half_angle_deg'} <= set(cone):
                raise CampaignError(file, f'{where}.exclude_cone', 'must be a mapping of axis, half_angle_deg and '
                                                                   f'optional both_ways, got {short_repr(cone)}')
            self._cone = _exclude_cone(cone, file, f'{where}.exclude_cone')
        self._axis_p = spec.get('axis_probability')
        if self._axis_p is not None and (isinstance(self._axis_p, bool) or not isinstance(self._axis_p, (int, float))
                                         or not 0.0 <= self._axis_p <= 1.0):
            raise CampaignError(file, f'{where}.axis_probability',
                                f'must be a number in [0, 1], got {describe(self._axis_p)}')
        if self._axis_p is not None and self._cone is not None:
            raise CampaignError(file, f'{where}.axis_probability', 'cannot be combined with exclude_cone')
        self._magnitude = None
        if spec.get('magnitude') is not None:
            self._magnitude = Dispersion(f'{self.key}.magnitude', spec['magnitude'], file, nested=True)
            if self._magnitude.kind in ('direction', 'box_surface_point', 'choice', 'scale'):
                raise CampaignError(file, f'{where}.magnitude', 'must be a number, uniform or normal')

    def _init_box_surface_point(self, spec, file, where, boxes, base_value):
        names = spec.get('boxes')
        index = range(len(boxes.names))
        if names is not None:
            if not isinstance(names, list) or not names:
                raise CampaignError(file, f'{where}.boxes',
                                    f'must be a non-empty list of box names, got {short_repr(names)}')
            unknown = [n for n in names if n not in boxes.names]
            if unknown:
                raise CampaignError(file, f'{where}.boxes', f'no target box named {short_repr(unknown[0])}, '
                                                            f'the boxes are {list(boxes.names)}')
            index = [boxes.names.index(n) for n in names]
        self._centers = boxes.center_body_m[list(index)]
        self._sizes = boxes.size_m[list(index)]
        sx, sy, sz = self._sizes.T
        # Faces of each box in order (-x, +x, -y, +y, -z, +z); area of a face normal to axis k.
        self._face_area_m2 = np.repeat(np.stack([sy * sz, sx * sz, sx * sy], axis=1), 2, axis=1).ravel()

    def _init_choice(self, spec, file, where, boxes, base_value):
        self._values = spec['values']
        if not isinstance(self._values, list) or not self._values:
            raise CampaignError(file, f'{where}.values',
                                f'must be a non-empty list, got {short_repr(self._values)}')
        weights = spec.get('weights')
        if weights is None:
            self._p = np.full(len(self._values), 1.0 / len(self._values))
            return
        w = _number_array(weights, file, f'{where}.weights', 'weights')
        if w.shape != (len(self._values),):
            raise CampaignError(file, f'{where}.weights', f'must give one weight per value '
                                                          f'({len(self._values)}), got {short_repr(weights)}')
        if np.any(w < 0.0) or w.sum() <= 0.0:
            raise CampaignError(file, f'{where}.weights',
                                f'must be >= 0 with a positive sum, got {short_repr(weights)}')
        self._p = w / w.sum()

    def _init_scale(self, spec, file, where, boxes, base_value):
        if base_value is None:
            raise CampaignError(file, where, 'scale needs a value in the base scenario to multiply')
        _number_array(base_value, file, where, 'the base value to scale')
        self._factor = Dispersion(f'{self.key}.factor', spec['factor'], file, nested=True)
        if self._factor.kind in ('direction', 'box_surface_point', 'choice', 'scale'):
            raise CampaignError(file, f'{where}.factor', 'must be a number, uniform or normal')

    def _broadcast(self, file, where, base_value, *params):
        try:
            shape = np.broadcast_shapes(*(p.shape for p in params))
        except ValueError:
            raise CampaignError(file, where, 'parameters have different lengths') from None
        if base_value is not None:
            base_shape = np.shape(base_value)
            if shape and shape != base_shape:
                raise CampaignError(file, where, f'gives {shape[0]} components, the scenario value has '
                                                 f'{base_shape[0] if base_shape else "none (a scalar)"}')
            return base_shape  # scalar parameters of a vector value: every component drawn alike
        return shape

    # -- draws ------------------------------------------------------------------------------------
    def draw(self, rng, base_value=None):
        """One draw from ``rng`` (a numpy Generator), as plain Python."""
        return getattr(self, f'_draw_{self.kind}')(rng, base_value)

    def _draw_constant(self, rng, base_value):
        return self._constant

    def _draw_uniform(self, rng, base_value):
        return _plain(rng.uniform(self._low, self._high, size=self._shape))

    def _draw_normal(self, rng, base_value):
        return _plain(rng.normal(self._mean, self._sigma, size=self._shape))

    def _draw_direction(self, rng, base_value):
        if self._axis_p is not None and rng.uniform() < self._axis_p:
            u = np.zeros(3)
            u[rng.integers(3)] = rng.choice((-1.0, 1.0))
            magnitude = 1.0 if self._magnitude is None else self._magnitude.draw(rng)
            return _plain(magnitude * u)
        # An isotropic normal 3-vector, normalized, is uniform on the sphere; rejecting the excluded
        # cone keeps it uniform on what remains.
        for _ in range(_MAX_REJECTIONS):
            u = rng.normal(size=3)
            u /= np.linalg.norm(u)
            if self._cone is None:
                break
            axis, cos_half, both = self._cone
            c = float(u @ axis)
            if c < cos_half and not (both and -c >= cos_half):
                break
        else:
            raise RuntimeError(f'{self.key}: no direction outside the excluded cone in {_MAX_REJECTIONS} draws')
        magnitude = 1.0 if self._magnitude is None else self._magnitude.draw(rng)
        return _plain(magnitude * u)

    def _draw_box_surface_point(self, rng, base_value):
        face = rng.choice(self._face_area_m2.size, p=self._face_area_m2 / self._face_area_m2.sum())
        box, side = divmod(face, 6)
        axis, sign = divmod(side, 2)
        half = 0.5 * self._sizes[box]
        p = rng.uniform(-half, half)
        p[axis] = half[axis] if sign else -half[axis]
        return _plain(self._centers[box] + p)

    def _draw_choice(self, rng, base_value):
        return copy.deepcopy(self._values[rng.choice(len(self._values), p=self._p)])

    def _draw_scale(self, rng, base_value):
        return _plain(np.asarray(base_value, dtype=float) * self._factor.draw(rng))


# --------------------------------------------------------------------------------------------------
# Keys of the scenario

def _schema_node(path):
    """The schema nodes from the root to a dotted path (Sections, ListOfs, Fields), or None where it leaves
    the schema; list indices pass through a ListOf to its item."""
    nodes = [SCHEMA]
    for part in path.split('.'):
        node = nodes[-1]
        if isinstance(node, ListOf):
            if not part.isdigit():
                return None
            nodes.append(node.item)
        elif isinstance(node, Section) and part in node.fields:
            nodes.append(node.fields[part])
        else:
            return None
    return nodes


def _parent_and_leaf(d, path):
    """The container holding the last part of ``path`` in the dict ``d``, and that part (str or int)."""
    parts = path.split('.')
    node = d
    for part in parts[:-1]:
        node = node[int(part)] if isinstance(node, list) else node[part]
    leaf = parts[-1]
    return node, int(leaf) if isinstance(node, list) else leaf


def _check_key(file, key, base, section='dispersions', whole=False):
    """The base value at ``key`` (None when absent: a one-of alternative or an optional key); raises
    CampaignError (naming ``section``.key) when the key is not a key of the scenario, or names a section or a list
    unless ``whole`` (a choice's key)."""
    where = f'{section}.{_short_key(key)}'
    if key in _RESERVED_KEYS:
        raise CampaignError(file, where, f'{key!r} is set by the campaign, not {section}')
    nodes = _schema_node(key)
    if nodes is None:
        raise CampaignError(file, where, 'not a key of the scenario (docs/scenario.md)')
    if isinstance(nodes[-1], (Section, ListOf)) and not whole:
        raise CampaignError(file, where, 'names a section or a list, not a value: disperse its keys one by one, '
                                         'or draw it whole with a choice')
    try:
        parent, leaf = _parent_and_leaf(base, key)
    except (KeyError, IndexError, TypeError):
        parent = None
    if not isinstance(parent, (dict, list)):  # an optional section the base leaves out (null) or a bad index
        raise CampaignError(file, where, 'not in the base scenario (its section is absent or the index is '
                                         'out of range)')
    if isinstance(leaf, int) and leaf >= len(parent):
        raise CampaignError(file, where, f'index {leaf} out of range ({len(parent)} items)')
    return _get(base, key)


def _check_section_choice(file, key, values, base):
    """Each value of a choice over the section ``key``: a non-empty mapping of keys below it, each a key of the
    scenario in the base (``_check_key``); raises CampaignError."""
    for i, value in enumerate(values):
        if not isinstance(value, dict) or not value:
            raise CampaignError(file, f'dispersions.{key}.values', f'a choice of the section {key} takes mappings '
                                                                   f'of its keys, got item {i}: {short_repr(value)}')
        for sub in value:
            _check_key(file, f'{key}.{sub}', base, whole=True)


def _get(d, key):
    """The value at ``key`` in the dict ``d``, None when absent."""
    parent, leaf = _parent_and_leaf(d, key)
    return parent[leaf] if isinstance(leaf, int) else parent.get(leaf)


def set_values(d, values):
    """Set each dotted scenario key of ``values`` in the scenario mapping ``d`` (a campaign's draws or overrides)."""
    for key, value in values.items():
        _set(d, str(key), value)


def _set(d, key, value):
    """Set ``key`` in the dict ``d`` to value, removing the other alternatives of its one-of group; a mapping
    for a section sets its keys one by one (a choice over a section)."""
    if isinstance(_schema_node(key)[-1], Section) and isinstance(value, dict):
        for sub, v in value.items():
            _set(d, f'{key}.{sub}', v)
        return
    parent, leaf = _parent_and_leaf(d, key)
    parent[leaf] = value
    section = _schema_node(key)[-2]
    for group in getattr(section, 'one_of', ()):
        if leaf in group:
            for other in group:
                if other != leaf:
                    parent.pop(other, None)


# --------------------------------------------------------------------------------------------------
# The campaign

class Campaign:
    """A loaded campaign: ``path``, ``name``, ``seed``, ``runs``, ``base`` (the base Scenario),
    ``dispersions`` (in file order), ``sha256`` (of the campaign file and the base scenario file)."""

    def __init__(self, path, name, seed, runs, base, dispersions, sha256):
        self.path, self.name, self.seed, self.runs = path, name, seed, runs
        self.base, self.dispersions, self.sha256 = base, tuple(dispersions), sha256

    @property
    def keys(self):
        """The dispersed keys, in file order."""
        return tuple(d.key for d in self.dispersions)

    def rng(self, run):
        """The generator of run ``run``: seeded by [campaign seed, run] alone."""
        return np.random.default_rng(np.random.SeedSequence([self.seed, run]))

    def draw_values(self, run):
        """(scenario seed, {key: drawn value}) of run ``run``, in file order."""
        rng = self.rng(run)
        seed = int(rng.integers(SCENARIO_SEED_BOUND))
        base = self.base.to_dict()
        values = {}
        for d in self.dispersions:
            values[d.key] = d.draw(rng, _get(base, d.key))
        return seed, values

    def scenario_dict(self, run):
        """The full scenario mapping of run ``run`` (base values, drawn values, drawn seed)."""
        return self._scenario_dict(run, *self.draw_values(run))

    def _scenario_dict(self, run, seed, values):
        d = self.base.to_dict()
        d['seed'] = seed
        d['name'] = f'{self.base.name}_{self.name}_{run}'
        d['description'] = f'Run {run} of campaign {self.name} ({self.path}, campaign seed {self.seed}).'
        set_values(d, values)
        return d

    def draw(self, run):
        """(Scenario, {key: drawn value}) of run ``run``; raises CampaignError if it is not a valid scenario."""
        seed, values = self.draw_values(run)
        try:
            scenario = scenario_from_dict(self._scenario_dict(run, seed, values), name=f'{self.path} run {run}')
        except ScenarioError as e:
            raise CampaignError(self.path, f'dispersions.{e.key}', f'run {run} draws an invalid scenario: '
                                                                   f'{e.problem}') from None
        return scenario, values


def load_campaign(path, checked_draws=None):
    """Load and check a campaign file; runs 0 to ``checked_draws`` - 1 (default: all the file's ``runs``; a
    runner flying another number of runs passes it) are drawn and validated by the scenario loader.

    Raises CampaignError (one line naming the file and the key, and the run of an invalid draw) on any problem.
    """
    file = str(path)
    try:
        data = load_yaml_mapping(path)
    except ScenarioError as e:
        raise CampaignError(file, e.key, e.problem) from None
    unknown = sorted(set(data) - _CAMPAIGN_KEYS, key=str)
    if unknown:
        raise CampaignError(file, _short_key(unknown[0]),
                            f'unknown campaign key, the keys are {sorted(_CAMPAIGN_KEYS)}')
    for k in ('base_scenario', 'seed', 'dispersions'):
        if k not in data:
            raise CampaignError(file, k, 'missing')
    seed = data['seed']
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= SEED_MAX:
        raise CampaignError(file, 'seed', f'must be an integer in [0, {SEED_MAX}], got {short_repr(seed)}')
    runs = data.get('runs', 1)
    if isinstance(runs, bool) or not isinstance(runs, int) or not 1 <= runs <= MAX_RUNS:
        raise CampaignError(file, 'runs', f'must be an integer in [1, {MAX_RUNS}], got {short_repr(runs)}')
    name = data.get('name', Path(path).stem)
    if not isinstance(name, str) or not name.strip():
        raise CampaignError(file, 'name', f'must be a non-empty string, got {describe(name)}')
    base_path = Path(path).parent / str(data['base_scenario'])
    try:
        base = load_scenario(base_path)
    except ScenarioError as e:
        raise CampaignError(file, 'base_scenario', str(e)) from None
    overrides = data.get('overrides') or {}
    if not isinstance(overrides, dict):
        raise CampaignError(file, 'overrides',
                            f'must be a mapping of scenario keys to values, got {short_repr(overrides)}')
    if overrides:
        base_dict = base.to_dict()
        for key in overrides:  # a list (the faults) may be set whole: the scenario built from it validates it
            nodes = _schema_node(str(key))
            whole = nodes is not None and isinstance(nodes[-1], ListOf)
            _check_key(file, str(key), base_dict, 'overrides', whole=whole)
        set_values(base_dict, overrides)
        try:
            base = scenario_from_dict(base_dict, name=base.name, path=base_path)
        except ScenarioError as e:
            raise CampaignError(file, f'overrides.{e.key}', e.problem) from None
    dispersions = data['dispersions'] or {}
    if not isinstance(dispersions, dict):
        raise CampaignError(file, 'dispersions',
                            f'must be a mapping of scenario keys, got {short_repr(dispersions)}')
    base_dict = base.to_dict()
    built = []
    for key, spec in dispersions.items():
        whole = isinstance(spec, dict) and spec.get('kind') == 'choice'
        built.append(Dispersion(str(key), spec, file, boxes=base.boxes,
                                base_value=_check_key(file, str(key), base_dict, whole=whole)))
        if whole and isinstance(_schema_node(str(key))[-1], Section):
            _check_section_choice(file, str(key), spec['values'], base_dict)
    sha = hashlib.sha256(Path(path).read_bytes() + b'\0' + base_path.read_bytes()).hexdigest()
    campaign = Campaign(file, name, seed, runs, base, built, sha)
    checked = runs if checked_draws is None else checked_draws
    if checked > MAX_RUNS:
        raise CampaignError(file, 'runs', f'must be at most {MAX_RUNS}, got {checked} (from the runs argument)')
    for run in range(checked):
        campaign.draw(run)  # CampaignError naming the run and the key of the first invalid draw
    return campaign

