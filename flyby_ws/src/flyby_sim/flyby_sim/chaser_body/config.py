"""The rigid-body chaser's configuration: inertia, initial attitude and rate, thruster layout, wheels, IMU; records
of the scenario (flyby_msgs_py.params: the schema holds the defaults), validated on construction (ValueError names
the field)."""

import math

from flyby_msgs_py import params
from flyby_sim.dynamics.actuators import ThrusterLayout, default_thruster_layout, is_positively_spanning
from flyby_sim.dynamics.attitude import validated_inertia
from flyby_sim.dynamics.checks import finite_vector, require_positive
from flyby_sim.dynamics.rigid_body import ReactionWheels
from flyby_sim.dynamics.rotation import quat_normalize

# No attitude substep turns the body or its rate vector by more than this (chaser_body module doc).
MAX_SUBSTEP_ANGLE_RAD = 0.01


def _rows(name, value, width=3):
    try:
        rows = tuple(finite_vector(f'{name}[{i}]', row, width) for i, row in enumerate(value))
    except TypeError as exc:
        raise ValueError(f'{name} must be a list of {width}-vectors, got {value!r}') from exc
    if not rows:
        raise ValueError(f'{name} must not be empty')
    return rows


def _vector(array):
    return tuple(array.tolist())


def _matrix(array):
    return tuple(map(tuple, array.tolist()))


def _layout_positions(scenario):
    layout = scenario.chaser.thrusters.layout
    return None if layout is None else tuple(tuple(x.position_m.tolist()) for x in layout)


def _layout_directions(scenario):
    layout = scenario.chaser.thrusters.layout
    return None if layout is None else tuple(tuple(x.direction.tolist()) for x in layout)


@params.record
class ImuConfig:
    """The chaser IMU's rates and noise (``sensors.ImuModel``; scenario sensors.chaser_imu)."""

    rate_hz: float = params.key('sensors.chaser_imu.rate_hz')  # gyro and accelerometer
    star_tracker_rate_hz: float = params.key('sensors.chaser_imu.star_tracker_rate_hz')  # rate_hz a whole multiple
    star_tracker_sigma_rad: float = params.key('sensors.chaser_imu.star_tracker_sigma_deg', math.radians)
    gyro_noise_sigma_rad_s: float = params.key('sensors.chaser_imu.gyro_noise_sigma_rad_s')
    gyro_bias_sigma_rad_s: float = params.key('sensors.chaser_imu.gyro_bias_sigma_rad_s')
    gyro_bias_walk_rad_s_sqrt_s: float = params.key('sensors.chaser_imu.gyro_bias_walk_rad_s_sqrt_s')
    accel_noise_sigma_mps2: float = params.key('sensors.chaser_imu.accel_noise_sigma_mps2')

    def __post_init__(self):
        require_positive('rate_hz', self.rate_hz)
        require_positive('star_tracker_rate_hz', self.star_tracker_rate_hz)
        for name in ('star_tracker_sigma_rad', 'gyro_noise_sigma_rad_s', 'gyro_bias_sigma_rad_s',
                     'gyro_bias_walk_rad_s_sqrt_s', 'accel_noise_sigma_mps2'):
            require_positive(name, getattr(self, name), allow_zero=True)
        ratio = self.rate_hz / self.star_tracker_rate_hz
        if ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-9 * ratio:
            raise ValueError(f'rate_hz {self.rate_hz} must be a whole multiple of star_tracker_rate_hz '
                             f'{self.star_tracker_rate_hz}')

    @property
    def star_tracker_every(self):
        """A star-tracker sample every this many IMU samples."""
        return round(self.rate_hz / self.star_tracker_rate_hz)


@params.record
class RigidChaserConfig:
    """The rigid-body chaser's own parameters (its rigid-body keys, whatever chaser.model says); validated on
    construction (ValueError names the field).

    The thrusters' maximum thrust, Isp, minimum impulse bit, largest delta-v and error sigmas are the
    plant's ``ThrusterConfig`` (per thruster here; the sigmas per run, module doc).
    """

    # 3x3 [kg m^2] about the CoM, chaser_body axes, wheels' spin-axis inertia left out
    inertia: tuple = params.key('chaser_inertia', _matrix)
    q_hill_from_body0: tuple = params.key('q_hill_from_chaser_body0', _vector)
    # inertial angular velocity at t = 0, body axes [rad/s]
    omega_body0: tuple = params.key('omega_chaser_body0_rad_s', _vector)
    thruster_positions_body_m: tuple = params.derived(_layout_positions)  # (N, 3); None: default_thruster_layout
    thruster_directions_body: tuple = params.derived(_layout_directions)  # (N, 3), normalized by ThrusterLayout
    wheel_axes_body: tuple = params.key('chaser.wheels.axes', _matrix)
    wheel_max_torque_n_m: float = params.key('chaser.wheels.max_torque_n_m')
    wheel_max_momentum_n_m_s: float = params.key('chaser.wheels.max_momentum_n_m_s')
    wheel_spin_inertia_kg_m2: float = params.key('chaser.wheels.spin_inertia_kg_m2')
    wheel_tachometer_sigma_rad_s: float = params.key('chaser.wheels.tachometer_sigma_rad_s')
    # one per wheel; None: zero (stored as zeros)
    wheel_momentum0_n_m_s: tuple = params.key('chaser.wheels.initial_momentum_n_m_s', _vector)
    imu: ImuConfig = params.sub(ImuConfig)

    def __post_init__(self):
        try:
            inertia = validated_inertia(self.inertia)
        except ValueError as exc:
            raise ValueError(f'inertia: {exc}') from exc
        object.__setattr__(self, 'inertia', tuple(map(tuple, inertia.tolist())))
        object.__setattr__(self, 'q_hill_from_body0', finite_vector('q_hill_from_body0', self.q_hill_from_body0, 4))
        try:
            quat_normalize(self.q_hill_from_body0)
        except ValueError as exc:
            raise ValueError(f'q_hill_from_body0: {exc}') from exc
        object.__setattr__(self, 'omega_body0', finite_vector('omega_body0', self.omega_body0, 3))
        if (self.thruster_positions_body_m is None) != (self.thruster_directions_body is None):
            raise ValueError('thruster_positions_body_m and thruster_directions_body must be given together')
        if self.thruster_positions_body_m is not None:
            object.__setattr__(self, 'thruster_positions_body_m',
                               _rows('thruster_positions_body_m', self.thruster_positions_body_m))
            object.__setattr__(self, 'thruster_directions_body',
                               _rows('thruster_directions_body', self.thruster_directions_body))
            if len(self.thruster_positions_body_m) != len(self.thruster_directions_body):
                raise ValueError('thruster_positions_body_m and thruster_directions_body differ in length')
            b = ThrusterLayout(self.thruster_positions_body_m, self.thruster_directions_body, 1.0, 1.0,
                               0.0).wrench_matrix
            if not is_positively_spanning(b):
                raise ValueError('thruster layout must give every body force and torque (rank 6, positively '
                                 'spanning)')
        object.__setattr__(self, 'wheel_axes_body', _rows('wheel_axes_body', self.wheel_axes_body))
        wheels = self.wheels()  # validates the axes and limits
        h0 = (0.0,) * wheels.count if self.wheel_momentum0_n_m_s is None else \
            finite_vector('wheel_momentum0_n_m_s', self.wheel_momentum0_n_m_s, wheels.count)
        if any(abs(h) > h_max for h, h_max in zip(h0, wheels.max_momentum_n_m_s.tolist(), strict=True)):
            raise ValueError(f'wheel_momentum0_n_m_s {h0} exceeds wheel_max_momentum_n_m_s '
                             f'{self.wheel_max_momentum_n_m_s}')
        object.__setattr__(self, 'wheel_momentum0_n_m_s', h0)
        if not isinstance(self.imu, ImuConfig):
            raise ValueError(f'imu must be an ImuConfig, got {self.imu!r}')

    def layout(self, thrusters):
        """The ThrusterLayout with the limits of thrusters (a propulsion.ThrusterConfig)."""
        if self.thruster_positions_body_m is None:
            return default_thruster_layout(thrusters.max_thrust_n, thrusters.isp_s, thrusters.min_impulse_bit_ns)
        return ThrusterLayout(self.thruster_positions_body_m, self.thruster_directions_body, thrusters.max_thrust_n,
                              thrusters.isp_s, thrusters.min_impulse_bit_ns)

    def wheels(self):
        """The ReactionWheels."""
        return ReactionWheels(self.wheel_axes_body, self.wheel_max_torque_n_m, self.wheel_max_momentum_n_m_s,
                              self.wheel_spin_inertia_kg_m2)
