"""The read-only result of a validated scenario: ``Scenario`` (sections by attribute, derived numpy values) and
``Boxes`` (the target geometry as arrays)."""

import copy
import math
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

from flyby_msgs_py.schema import Namespace
from flyby_sim.dynamics.actuators import ThrusterLayout, default_thruster_layout
from flyby_sim.dynamics.constants import EARTH_RADIUS_M
from flyby_sim.dynamics.grasp import Impedance
from flyby_sim.dynamics.orbital import mean_motion_rad_s
from flyby_sim.dynamics.rigid_body import ReactionWheels
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_multiply,
    quat_normalize,
    quat_rotate,
    quat_rotate_many,
    quat_shortest_arc,
)
from flyby_sim.scenario.schema import SCHEMA


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

    def centers_hill_m(self, q_hill_from_body, r_com_hill_m=(0.0, 0.0, 0.0)):
        """Box centres (N, 3) in hill for the target attitude ``q_hill_from_body`` and its CoM at
        ``r_com_hill_m``: r_com_hill + R(q_hill_from_body) center_body (each box keeps the body's
        orientation)."""
        return np.asarray(r_com_hill_m, dtype=float) + quat_rotate_many(q_hill_from_body, self.center_body_m)


class Scenario:
    """A validated scenario: read-only sections by attribute (``sc.chaser.thrusters.isp_s``) plus
    derived numpy values. Build it with ``load_scenario`` or ``scenario_from_dict``.

    A scenario of several chasers (``chasers:``) is one such view per chaser: ``chaser_name`` (None for one
    chaser), ``chaser_names`` (empty for one chaser) and ``for_chaser(name)``."""

    _fleet = ()
    chaser_name = None

    def __init__(self, resolved, raw, path=None):
        object.__setattr__(self, '_root', Namespace(resolved, SCHEMA))
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
    def chaser_names(self):
        """The chasers' names in the file's order (a ``chasers:`` scenario), else ()."""
        return tuple(n for n, _ in self._fleet)

    def for_chaser(self, name):
        """The view of chaser ``name`` (a ``chasers:`` scenario); raises KeyError naming the choices."""
        for n, view in self._fleet:
            if n == name:
                return view
        raise KeyError(f'no chaser {name!r} in scenario {self.name!r} (chasers: {list(self.chaser_names)})')

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
        chaser = self._root.chaser
        if chaser.initial_attitude is not None:
            q_chaser = _q_hill_from_body(chaser.initial_attitude)
        else:  # body +x at the target's CoM
            r0 = chaser.initial_position_hill_m
            q_chaser = _positive_w(quat_shortest_arc((1.0, 0.0, 0.0), -r0)) if any(r0) else np.array((0., 0., 0., 1.))
        omega_chaser = np.zeros(3) if chaser.initial_rate is None else _omega_body(chaser.initial_rate, q_chaser)
        if t.initial_attitude is not None:
            q = _q_hill_from_body(t.initial_attitude)
            omega = _omega_body(t.initial_rate, q)
        else:  # post_capture.start attached: the target turns with the chaser that holds it
            q_chaser_from_target = self.q_chaser_from_target_attached
            q = _positive_w(quat_multiply(q_chaser, q_chaser_from_target))
            omega = quat_rotate(quat_conjugate(q_chaser_from_target), omega_chaser)
        if chaser.inertia_kg_m2 is not None:
            chaser_inertia = np.array(chaser.inertia_kg_m2)
        else:  # a uniform sphere filling the envelope: 2/5 m r^2
            chaser_inertia = 0.4 * chaser.mass_kg * chaser.envelope_radius_m ** 2 * np.eye(3)
        orbit = self._root.orbit
        radius = orbit.radius_m if orbit.radius_m is not None else EARTH_RADIUS_M + orbit.altitude_m
        return {
            'q': q,
            'omega_body': omega,
            'q_chaser': q_chaser,
            'omega_chaser_body': omega_chaser,
            'chaser_inertia': chaser_inertia,
            'radius': float(radius),
            'n': mean_motion_rad_s(radius, orbit.mu_m3_s2),
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
        return Rotation.from_quat(self._derived['q'])

    @property
    def q_hill_from_body0(self):
        """Unit quaternion (x, y, z, w) of target_body in hill at t = 0, w >= 0; a fresh array."""
        return self._derived['q'].copy()

    @property
    def omega_body0_rad_s(self):
        """Inertial angular velocity of the target in target_body axes at t = 0 [rad/s]; a fresh array."""
        return self._derived['omega_body'].copy()

    @property
    def chaser_inertia(self):
        """Chaser inertia [kg m^2] in chaser_body axes (chaser.inertia_kg_m2, or the envelope sphere's); a fresh
        (3, 3) array."""
        return self._derived['chaser_inertia'].copy()

    @property
    def q_hill_from_chaser_body0(self):
        """Unit quaternion (x, y, z, w) of chaser_body in hill at t = 0, w >= 0 (chaser.initial_attitude, or body
        +x at the target's CoM); a fresh array."""
        return self._derived['q_chaser'].copy()

    @property
    def omega_chaser_body0_rad_s(self):
        """Inertial angular velocity of the chaser in chaser_body axes at t = 0 [rad/s] (zero if omitted)."""
        return self._derived['omega_chaser_body'].copy()

    @property
    def thruster_layout(self):
        """The rigid-body chaser's nominal ThrusterLayout (chaser.thrusters.layout, or the default 12 thrusters), as
        guidance allocates and the plant fires it (without the run's execution errors)."""
        th = self.chaser.thrusters
        if th.layout is None:
            return default_thruster_layout(th.max_thrust_n, th.isp_s, th.min_impulse_bit_ns)
        return ThrusterLayout([x.position_m for x in th.layout], [x.direction for x in th.layout], th.max_thrust_n,
                              th.isp_s, th.min_impulse_bit_ns)

    @property
    def reaction_wheels(self):
        """The rigid-body chaser's ReactionWheels (chaser.wheels: axes, limits, spin inertia)."""
        w = self.chaser.wheels
        return ReactionWheels(w.axes, w.max_torque_n_m, w.max_momentum_n_m_s, w.spin_inertia_kg_m2)

    @property
    def q_chaser_from_target_attached(self):
        """Unit quaternion (x, y, z, w) of target_body in chaser_body when the run starts attached
        (post_capture.attachment), else None."""
        pc = self.post_capture
        if pc is None or pc.attachment is None:
            return None
        return Rotation.from_euler('xyz', pc.attachment.target_rpy_in_chaser_rad).as_quat()

    @property
    def arm_impedance(self):
        """The arm's impedance after the capture (post_capture.grasp as a ``dynamics.grasp.Impedance``), or None
        without a post_capture section."""
        return None if self.post_capture is None else Impedance.from_scenario(self)

    @property
    def offset_max_m(self):
        """Largest fly-by offset delta r the planner searches [m] (planner.offset_max_m or the reach less
        the position tolerance)."""
        p, arm = self.planner, self.chaser.manipulator
        return p.offset_max_m if p.offset_max_m is not None else arm.reach_m - arm.position_tolerance_m

    @property
    def boxes(self):
        """Target geometry as arrays (``Boxes``: names, center_body_m (N, 3), size_m (N, 3))."""
        g = self._root.target.geometry
        return Boxes(tuple(b.name for b in g), np.array([b.center_m for b in g]), np.array([b.size_m for b in g]))


def _positive_w(q):
    """q or -q, whichever has w >= 0 (the same attitude)."""
    return -q if q[3] < 0.0 else q


def _q_hill_from_body(att):
    """The unit quaternion (w >= 0) of an initial_attitude section (any of its three forms)."""
    if att.q_hill_from_body is not None:
        q = quat_normalize(att.q_hill_from_body)
    elif att.rpy_rad is not None:
        q = Rotation.from_euler('xyz', att.rpy_rad).as_quat()  # extrinsic x-y-z = Rz(yaw) Ry(pitch) Rx(roll)
    else:
        q = quat_shortest_arc(att.body_axis_along_hill.body, att.body_axis_along_hill.hill)
    return _positive_w(q)  # q and -q are the same attitude: report w >= 0


def _omega_body(rate, q_hill_from_body):
    """The inertial angular velocity in body axes [rad/s] of an initial_rate section, given in body or hill axes."""
    if rate.omega_body_rad_s is not None:
        omega_body = np.array(rate.omega_body_rad_s)
    elif rate.omega_body_deg_s is not None:
        omega_body = np.radians(rate.omega_body_deg_s)
    else:
        omega_hill = (rate.omega_hill_rad_s if rate.omega_hill_rad_s is not None
                      else np.radians(rate.omega_hill_deg_s))
        omega_body = quat_rotate(quat_conjugate(q_hill_from_body), omega_hill)  # omega_B = R_BH omega_H
    return np.asarray(omega_body, dtype=float)

