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

Run i is drawn from ``np.random.default_rng(np.random.SeedSequence([campaign_seed, i]))`` alone: first
the run's scenario seed, then each dispersion in file order; so any run is redrawn alone, equal to
its draw in the whole campaign. Giving one alternative of a one-of group (``omega_hill_deg_s`` where
the base gave ``omega_body_deg_s``) removes the other alternatives of that group from the drawn scenario.

Every problem raises ``CampaignError`` (a ``ScenarioError``), one line ``<campaign file>: <key>: <problem>``,
before any run starts: unknown kinds, keys or parameters, keys not in the scenario, impossible ranges,
and a dispersion whose draws make an invalid scenario (the first ``CHECKED_DRAWS`` runs are validated).
"""

import copy
import hashlib
import math
from pathlib import Path

import numpy as np

from flyby_msgs_py.schema import ListOf, ScenarioError, Section, load_yaml_mapping
from flyby_sim.scenario import SCHEMA, load_scenario, scenario_from_dict

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
SCENARIO_SEED_BOUND = 2**31  # run seeds are drawn in [0, 2**31)
CHECKED_DRAWS = 5  # runs validated through the scenario schema before a campaign starts
_MAX_REJECTIONS = 10_000  # draws of a direction outside the excluded cone(s) before giving up


class CampaignError(ScenarioError):
    """An invalid campaign file: one line ``<file>: <key>: <problem>`` (key '' for file-level problems)."""


# --------------------------------------------------------------------------------------------------
# Draws of one dispersion

def _number_array(v, file, key, what):
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        raise CampaignError(file, key, f'{what} must be a number or a list of numbers, got {v!r}') from None
    if a.ndim > 2 or not np.all(np.isfinite(a)):
        raise CampaignError(file, key, f'{what} must be a finite number, a list of finite numbers or a matrix (a '
                                       f'list of equal lists, e.g. an inertia) of them, got {v!r}')
    return a


def _plain(x):
    """numpy scalars, vectors and matrices as plain Python floats and (nested) lists (YAML-dumpable, JSON-writable)."""
    a = np.asarray(x, dtype=float)
    return float(a) if a.ndim == 0 else a.tolist()


def _unit(v, file, key, what):
    a = _number_array(v, file, key, what)
    if a.shape != (3,) or np.linalg.norm(a) == 0.0:
        raise CampaignError(file, key, f'{what} must be a nonzero 3-vector, got {v!r}')
    return a / np.linalg.norm(a)


class Dispersion:
    """One dispersion: ``key`` (dotted scenario path), ``kind``, and ``draw(rng, base_value)``, the
    drawn value as plain Python (float, list of floats, or one of ``choice``'s values)."""

    def __init__(self, key, spec, file, boxes=None, base_value=None, nested=False):
        self.key = key
        self.spec = spec
        where = f'dispersions.{key}'
        if isinstance(spec, (int, float)) and nested:
            self.kind, self._constant = 'constant', float(spec)
            return
        if not isinstance(spec, dict) or 'kind' not in spec:
            raise CampaignError(file, where, f"must be a mapping with a 'kind' (one of {list(KINDS)}), got {spec!r}")
        self.kind = spec['kind']
        if self.kind not in KINDS:
            raise CampaignError(file, f'{where}.kind', f'unknown dispersion kind {self.kind!r}, one of {list(KINDS)}')
        required, optional = _PARAMS[self.kind]
        for p in required:
            if p not in spec:
                raise CampaignError(file, where, f'{self.kind} needs {p!r}')
        for p in spec:
            if p != 'kind' and p not in required + optional:
                raise CampaignError(file, f'{where}.{p}', f'unknown parameter of {self.kind}, '
                                                          f'it takes {list(required + optional)}')
        getattr(self, f'_init_{self.kind}')(spec, file, where, boxes, base_value)

    # -- parameters, checked once -----------------------------------------------------------------
    def _init_uniform(self, spec, file, where, boxes, base_value):
        self._low = _number_array(spec['low'], file, f'{where}.low', 'low')
        self._high = _number_array(spec['high'], file, f'{where}.high', 'high')
        bad = np.flatnonzero(np.broadcast_to(self._low > self._high, np.broadcast_shapes(self._low.shape,
                                                                                        self._high.shape)))
        if bad.size:
            raise CampaignError(file, where, f'low > high: low {spec["low"]!r}, high {spec["high"]!r}')
        self._shape = self._broadcast(file, where, base_value, self._low, self._high)

    def _init_normal(self, spec, file, where, boxes, base_value):
        self._mean = _number_array(spec['mean'], file, f'{where}.mean', 'mean')
        self._sigma = _number_array(spec['sigma'], file, f'{where}.sigma', 'sigma')
        if np.any(self._sigma < 0.0):
            raise CampaignError(file, f'{where}.sigma', f'must be >= 0, got {spec["sigma"]!r}')
        self._shape = self._broadcast(file, where, base_value, self._mean, self._sigma)

    def _init_direction(self, spec, file, where, boxes, base_value):
        self._cone = None
        cone = spec.get('exclude_cone')
        if cone is not None:
            unknown = set(cone) - {'axis', 'half_angle_deg', 'both_ways'} if isinstance(cone, dict) else None
            if unknown is None or unknown or not {'axis', 'half_angle_deg'} <= set(cone):
                raise CampaignError(file, f'{where}.exclude_cone',
                                    f'must be a mapping of axis, half_angle_deg and optional both_ways, got {cone!r}')
            axis = _unit(cone['axis'], file, f'{where}.exclude_cone.axis', 'axis')
            half = float(cone['half_angle_deg'])
            both = bool(cone.get('both_ways', False))
            if not 0.0 <= half < (90.0 if both else 180.0):
                raise CampaignError(file, f'{where}.exclude_cone.half_angle_deg',
                                    f'must be in [0, {90 if both else 180}) (some direction must remain), got {half!r}')
            self._cone = (axis, math.cos(math.radians(half)), both)
        self._axis_p = spec.get('axis_probability')
        if self._axis_p is not None and not (isinstance(self._axis_p, (int, float)) and 0.0 <= self._axis_p <= 1.0):
            raise CampaignError(file, f'{where}.axis_probability', f'must be a number in [0, 1], got {self._axis_p!r}')
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
                raise CampaignError(file, f'{where}.boxes', f'must be a non-empty list of box names, got {names!r}')
            unknown = [n for n in names if n not in boxes.names]
            if unknown:
                raise CampaignError(file, f'{where}.boxes', f'no target box named {unknown[0]!r}, '
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
            raise CampaignError(file, f'{where}.values', f'must be a non-empty list, got {self._values!r}')
        weights = spec.get('weights')
        if weights is None:
            self._p = np.full(len(self._values), 1.0 / len(self._values))
            return
        w = _number_array(weights, file, f'{where}.weights', 'weights')
        if w.shape != (len(self._values),):
            raise CampaignError(file, f'{where}.weights', f'must give one weight per value '
                                                          f'({len(self._values)}), got {weights!r}')
        if np.any(w < 0.0) or w.sum() <= 0.0:
            raise CampaignError(file, f'{where}.weights', f'must be >= 0 with a positive sum, got {weights!r}')
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


def _check_key(file, key, base, section='dispersions'):
    """The base value at ``key`` (None when absent: a one-of alternative or an optional key); raises
    CampaignError (naming ``section``.key) when the key is not a key of the scenario."""
    where = f'{section}.{key}'
    if key in _RESERVED_KEYS:
        raise CampaignError(file, where, f'{key!r} is set by the campaign, not {section}')
    nodes = _schema_node(key)
    if nodes is None:
        raise CampaignError(file, where, 'not a key of the scenario (docs/scenario.md)')
    if isinstance(nodes[-1], (Section, ListOf)):
        raise CampaignError(file, where, 'names a section, not a value: disperse its keys one by one')
    try:
        parent, leaf = _parent_and_leaf(base, key)
    except (KeyError, IndexError, TypeError):
        raise CampaignError(file, where, 'not in the base scenario (its section is absent or the index is '
                                         'out of range)') from None
    if isinstance(leaf, int) and leaf >= len(parent):
        raise CampaignError(file, where, f'index {leaf} out of range ({len(parent)} items)')
    return _get(base, key)


def _get(d, key):
    """The value at ``key`` in the dict ``d``, None when absent."""
    parent, leaf = _parent_and_leaf(d, key)
    return parent[leaf] if isinstance(leaf, int) else parent.get(leaf)


def set_values(d, values):
    """Set each dotted scenario key of ``values`` in the scenario mapping ``d`` (a campaign's draws or overrides)."""
    for key, value in values.items():
        _set(d, str(key), value)


def _set(d, key, value):
    """Set ``key`` in the dict ``d`` to value, removing the other alternatives of its one-of group."""
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
        seed, values = self.draw_values(run)
        d = self.base.to_dict()
        d['seed'] = seed
        d['name'] = f'{self.base.name}_{self.name}_{run}'
        d['description'] = f'Run {run} of campaign {self.name} ({self.path}, campaign seed {self.seed}).'
        set_values(d, values)
        return d

    def draw(self, run):
        """(Scenario, {key: drawn value}) of run ``run``; raises CampaignError if it is not a valid scenario."""
        _, values = self.draw_values(run)
        try:
            scenario = scenario_from_dict(self.scenario_dict(run), name=f'{self.path} run {run}')
        except ScenarioError as e:
            raise CampaignError(self.path, f'dispersions.{e.key}', f'run {run} draws an invalid scenario: '
                                                                   f'{e.problem}') from None
        return scenario, values


def load_campaign(path, checked_draws=CHECKED_DRAWS):
    """Load and check a campaign file; the first ``checked_draws`` runs are drawn and validated.

    Raises CampaignError (one line naming the file and the key) on any problem.
    """
    file = str(path)
    data = load_yaml_mapping(path)
    unknown = sorted(set(data) - _CAMPAIGN_KEYS)
    if unknown:
        raise CampaignError(file, unknown[0], f'unknown campaign key, the keys are {sorted(_CAMPAIGN_KEYS)}')
    for k in ('base_scenario', 'seed', 'dispersions'):
        if k not in data:
            raise CampaignError(file, k, 'missing')
    seed = data['seed']
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise CampaignError(file, 'seed', f'must be an integer >= 0, got {seed!r}')
    runs = data.get('runs', 1)
    if isinstance(runs, bool) or not isinstance(runs, int) or runs < 1:
        raise CampaignError(file, 'runs', f'must be an integer >= 1, got {runs!r}')
    base_path = Path(path).parent / str(data['base_scenario'])
    try:
        base = load_scenario(base_path)
    except ScenarioError as e:
        raise CampaignError(file, 'base_scenario', str(e)) from None
    overrides = data.get('overrides') or {}
    if not isinstance(overrides, dict):
        raise CampaignError(file, 'overrides', f'must be a mapping of scenario keys to values, got {overrides!r}')
    if overrides:
        base_dict = base.to_dict()
        for key in overrides:
            _check_key(file, str(key), base_dict, 'overrides')
        set_values(base_dict, overrides)
        try:
            base = scenario_from_dict(base_dict, name=base.name, path=base_path)
        except ScenarioError as e:
            raise CampaignError(file, f'overrides.{e.key}', e.problem) from None
    dispersions = data['dispersions'] or {}
    if not isinstance(dispersions, dict):
        raise CampaignError(file, 'dispersions', f'must be a mapping of scenario keys, got {dispersions!r}')
    base_dict = base.to_dict()
    built = [Dispersion(str(key), spec, file, boxes=base.boxes, base_value=_check_key(file, str(key), base_dict))
             for key, spec in dispersions.items()]
    sha = hashlib.sha256(Path(path).read_bytes() + b'\0' + base_path.read_bytes()).hexdigest()
    campaign = Campaign(file, str(data.get('name', Path(path).stem)), seed, runs, base, built, sha)
    for run in range(min(checked_draws, runs)):
        campaign.draw(run)
    return campaign

