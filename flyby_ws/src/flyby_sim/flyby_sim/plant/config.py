"""The plant's configuration and what a step returns: truth and sensor samples.

``PlantConfig`` and ``GraspConfig`` are records of the scenario (``flyby_msgs_py.params``: each field names its key,
the schema holds the defaults; ``PlantConfig.from_scenario(scenario)``), validated on construction: a test builds one
from a loaded scenario and changes what it needs with ``dataclasses.replace``."""

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from flyby_msgs_py import params
from flyby_sim.chaser_body import RigidChaserConfig
from flyby_sim.dynamics.attitude import validated_inertia
from flyby_sim.dynamics.checks import finite_vector, require_positive
from flyby_sim.dynamics.grasp import Impedance
from flyby_sim.dynamics.propulsion import ThrusterConfig
from flyby_sim.dynamics.rotation import quat_normalize
from flyby_sim.faults import FaultSpec, fault_specs

DYNAMICS = ('nonlinear', 'cw')


def _tuple(value):
    return tuple(value)


def _matrix(array):
    return tuple(map(tuple, array))


def _is_rigid_body(scenario):
    return scenario.chaser.model == 'rigid_body'


def _has_post_capture(scenario):
    return scenario.post_capture is not None


@params.record
class GraspConfig:
    """The arm after the capture (scenario ``post_capture.grasp``; validated, ValueError names the field)."""

    impedance: Impedance = params.sub(Impedance)
    target_mass_kg: float = params.key('target.mass_kg')
    grasp_point_body_m: tuple = params.key('target.grasp_point_body_m', _tuple)  # the handle, from its CoM [m]
    # damped once the relative velocity and rate stay below these
    velocity_tolerance_mps: float = params.key('post_capture.grasp.velocity_tolerance_mps')
    rate_tolerance_rad_s: float = params.key('post_capture.grasp.rate_tolerance_rad_s')
    max_duration_s: float = params.key('post_capture.grasp.max_duration_s')  # locked at the latest this long after
    # Starting attached (scenario post_capture.start attached, seed 004 §3.1): the target's CoM X_s from the chaser's
    # CoM [m] and its attitude in the chaser's, (x, y, z, w), from t = 0; None: the run starts free.
    attached_target_com_body_m: tuple = params.key('post_capture.attachment.target_com_chaser_body_m', _tuple)
    q_chaser_from_target: tuple = params.key('q_chaser_from_target_attached', _tuple)
    # Transport (scenario post_capture.transport): the half-angle of the cone about the target's CoM that no
    # thruster's exhaust may point into once TRANSPORT starts [deg]; None: no transport.
    transport_plume_cone_deg: float = params.key('post_capture.transport.plume_cone_deg')

    def __post_init__(self):
        if not isinstance(self.impedance, Impedance):
            raise ValueError(f'impedance must be a grasp.Impedance, got {self.impedance!r}')
        for name in ('target_mass_kg', 'velocity_tolerance_mps', 'rate_tolerance_rad_s', 'max_duration_s'):
            require_positive(name, getattr(self, name))
        object.__setattr__(self, 'grasp_point_body_m', finite_vector('grasp_point_body_m', self.grasp_point_body_m, 3))
        if (self.attached_target_com_body_m is None) != (self.q_chaser_from_target is None):
            raise ValueError('attached_target_com_body_m and q_chaser_from_target go together (start attached) or '
                             'are both None')
        if self.attached_target_com_body_m is not None:
            object.__setattr__(self, 'attached_target_com_body_m',
                               finite_vector('attached_target_com_body_m', self.attached_target_com_body_m, 3))
            object.__setattr__(self, 'q_chaser_from_target', tuple(quat_normalize(
                finite_vector('q_chaser_from_target', self.q_chaser_from_target, 4))))

    @property
    def start_attached(self):
        """True when the run starts with the chaser holding the target."""
        return self.attached_target_com_body_m is not None


@params.record
class PlantConfig:
    """Everything the plant needs; validated on construction (ValueError names the field)."""

    radius_m: float = params.key('orbit_radius_m')  # circular target orbit radius
    mu: float = params.key('orbit.mu_m3_s2')
    chaser_mass_kg: float = params.key('chaser.mass_kg')
    r0_hill: tuple = params.key('chaser.initial_position_hill_m', _tuple)  # chaser position at t = 0 [m]
    # chaser velocity relative to the rotating hill frame at t = 0 [m/s]
    v0_hill: tuple = params.key('chaser.initial_velocity_hill_mps', _tuple)
    target_inertia: tuple = params.key('target_inertia', _matrix)  # 3x3 [kg m^2], body axes
    q_hill_from_body0: tuple = params.key('q_hill_from_body0', _tuple)  # target attitude at t = 0, (x, y, z, w)
    # target inertial angular velocity at t = 0, body axes [rad/s]
    omega_body0: tuple = params.key('omega_body0_rad_s', _tuple)
    thrusters: ThrusterConfig = params.sub(ThrusterConfig)
    dynamics: str = params.key('simulation.dynamics')  # 'nonlinear' (seed 000 eq 1) or 'cw' (eq 2)
    step_s: float = params.key('simulation.step_s')
    position_sigma_m: float = params.key('sensors.relative_position.noise_sigma_m')
    position_rate_hz: float = params.key('sensors.relative_position.rate_hz')
    attitude_sigma_rad: float = params.key('sensors.target_attitude.noise_sigma_deg', math.radians)
    attitude_rate_hz: float = params.key('sensors.target_attitude.rate_hz')
    restriction_sphere_radius_m: float = params.key('planner.restriction_sphere_radius_m')
    seed: int = params.key('seed')
    # None: the point-mass chaser
    chaser_body: RigidChaserConfig = params.sub(RigidChaserConfig, when=_is_rigid_body)
    # None: the capture welds the chaser to the target (module doc)
    grasp: GraspConfig = params.sub(GraspConfig, when=_has_post_capture)
    faults: tuple = params.key('faults', fault_specs)  # the injected faults (FaultSpec), in the scenario's order

    def __post_init__(self):
        object.__setattr__(self, 'faults', () if self.faults is None else tuple(self.faults))
        if not all(isinstance(f, FaultSpec) for f in self.faults):
            raise ValueError(f'faults must be FaultSpecs, got {self.faults!r}')
        for name in ('radius_m', 'chaser_mass_kg', 'mu', 'step_s', 'position_rate_hz', 'attitude_rate_hz'):
            require_positive(name, getattr(self, name))
        for name in ('position_sigma_m', 'attitude_sigma_rad', 'restriction_sphere_radius_m'):
            require_positive(name, getattr(self, name), allow_zero=True)
        for name, size in (('r0_hill', 3), ('v0_hill', 3), ('q_hill_from_body0', 4), ('omega_body0', 3)):
            object.__setattr__(self, name, finite_vector(name, getattr(self, name), size))
        try:
            inertia = validated_inertia(self.target_inertia)
        except ValueError as exc:
            raise ValueError(f'target_inertia: {exc}') from exc
        object.__setattr__(self, 'target_inertia', tuple(map(tuple, inertia.tolist())))
        try:
            quat_normalize(self.q_hill_from_body0)
        except ValueError as exc:
            raise ValueError(f'q_hill_from_body0: {exc}') from exc
        if self.dynamics not in DYNAMICS:
            raise ValueError(f'dynamics must be one of {DYNAMICS}, got {self.dynamics!r}')
        if not isinstance(self.thrusters, ThrusterConfig):
            raise ValueError(f'thrusters must be a ThrusterConfig, got {self.thrusters!r}')
        for name in ('position_rate_hz', 'attitude_rate_hz'):
            if getattr(self, name) * self.step_s > 1.0:
                raise ValueError(f'{name} = {getattr(self, name)} exceeds one sample per step '
                                 f'(step_s = {self.step_s})')
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise ValueError(f'seed must be a non-negative integer, got {self.seed!r}')
        if self.chaser_body is not None:
            if not isinstance(self.chaser_body, RigidChaserConfig):
                raise ValueError(f'chaser_body must be a RigidChaserConfig or None, got {self.chaser_body!r}')
            if self.chaser_body.imu.rate_hz * self.step_s > 1.0:
                raise ValueError(f'chaser_body.imu.rate_hz = {self.chaser_body.imu.rate_hz} exceeds one sample per '
                                 f'step (step_s = {self.step_s})')
        if self.grasp is not None:
            if not isinstance(self.grasp, GraspConfig):
                raise ValueError(f'grasp must be a GraspConfig or None, got {self.grasp!r}')
            if self.chaser_body is None:
                raise ValueError('grasp needs the rigid-body chaser (chaser_body)')

    @property
    def rigid_body(self):
        """True for the six-degree-of-freedom chaser."""
        return self.chaser_body is not None


@dataclasses.dataclass(frozen=True, slots=True)
class TruthSample:
    """True state at the end of a step (hill frame; arrays are the caller's to keep)."""

    t: float  # [s]
    r_hill: np.ndarray  # chaser position [m]
    v_hill: np.ndarray  # chaser velocity relative to the rotating frame [m/s]
    q_hill_from_body: np.ndarray  # target attitude (x, y, z, w)
    omega_body: np.ndarray  # target inertial angular velocity, body axes [rad/s]
    force_hill: np.ndarray  # mean thrust force over the step (impulse / step_s) [N]
    mass_kg: float  # chaser mass
    fuel_used_kg: float  # since t = 0
    dv_applied_total_mps: float  # sum of |delta-v| delivered by the thrusters since t = 0
    firing: bool  # thrust was on during some part of the step
    # The six-degree-of-freedom chaser only (None for the point mass); means are over the step.
    q_hill_from_chaser_body: np.ndarray = None  # chaser attitude (x, y, z, w)
    omega_chaser_body: np.ndarray = None  # chaser inertial angular velocity, chaser_body axes [rad/s]
    wheel_momentum_n_m_s: np.ndarray = None  # (N,) each wheel's axial angular momentum
    wheel_speed_rad_s: np.ndarray = None  # (N,) each wheel's spin rate relative to the body
    wheel_torque_n_m: np.ndarray = None  # (N,) mean motor torque applied (limits included)
    force_body_n: np.ndarray = None  # mean thrust force, chaser_body axes [N]
    torque_body_n_m: np.ndarray = None  # mean thrust torque about the CoM, chaser_body axes [N m]
    torque_hill_n_m: np.ndarray = None  # the same torque in hill axes (angular impulse / step_s) [N m]
    thruster_thrust_n: np.ndarray = None  # (M,) mean thrust of each thruster, errors included [N]
    gyro_bias_rad_s: np.ndarray = None  # the IMU gyro's bias (as of its latest sample) [rad/s]
    # The target's CoM off the hill origin after a grasp (None: at the origin): position and velocity relative to the
    # rotating frame, hill axes [m, m/s].
    r_target_hill: np.ndarray = None
    v_target_hill: np.ndarray = None


class Measurement(NamedTuple):
    """One sensor sample: kind 'relative_position' (value r_hill [m]), 'target_attitude' (q_hill_from_body) or,
    for the six-degree-of-freedom chaser, 'chaser_imu' (a sensors.ImuSample) and, with it, 'wheel_speeds' (each
    wheel's tachometer [rad/s])."""

    kind: str
    t: float
    value: np.ndarray

