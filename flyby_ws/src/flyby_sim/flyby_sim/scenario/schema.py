"""The flyby scenario schema: one line per key (type, default or REQUIRED, range, description).

The engine is ``flyby_msgs_py.schema``; ``docs/scenario.md`` embeds the table ``schema_markdown()`` renders from
``SCHEMA``. Checks a range cannot express are ``scenario.checks`` and ``scenario.plausibility``. An angle, rate,
time, distance or speed whose line states no upper bound gets its unit's, ``UNIT_BOUNDS``; every number is within the
engine's ``MAGNITUDE_RANGE``; every seed within [0, ``SEED_MAX``].
"""

import dataclasses
import math

from flyby_msgs_py.schema import (
    BOOL,
    ENUM,
    FLOAT,
    FLOAT_LIST,
    INT,
    MAT3,
    QUAT,
    REQUIRED,
    STR,
    VEC3,
    VEC3_LIST,
    Field,
    ListOf,
    Section,
    check_nonempty,
    unit_of,
)
from flyby_sim.dynamics.constants import EARTH_RADIUS_M, MU_EARTH_M3_S2
from flyby_sim.scenario.checks import check_direction, check_direction_rows, check_inertia, check_unique_names
from flyby_sim.scenario.fault_schema import FAULTS

MAX_STEP_S = 0.05  # truth is published every step and must reach >= 20 Hz (DESIGN §4)
MIN_STEP_S = 0.001  # finer than any dynamics of the problem: a smaller step only makes the run endless
SEED_MAX = 2**32 - 1  # every seed (the scenario's, --seed, --first-seed, a campaign's): numpy's 32-bit word
MAX_ORBIT_RADIUS_M = 1e9  # beyond the Moon's orbit (3.8e8 m): no longer a relative-motion problem about a planet

# The range of a key of these units whose line states no upper bound, with the reason (what a physical user never
# reaches); a key's own range, when it has an upper bound, is kept.
UNIT_BOUNDS = {
    'rad': (6.3, 'an angle: one turn, 2 pi, either way reaches every attitude'),
    'deg': (360.0, 'an angle: one turn either way reaches every attitude'),
    'rad/s': (6.3, 'an angular rate: at most one turn, 2 pi rad, a second'),
    'deg/s': (360.0, 'an angular rate: at most one turn a second'),
    's': (1e6, 'a time: a run is at most 1e7 steps of at most 0.05 s, 5e5 s'),
    'm': (1e6, 'a length or a position of the relative motion, which starts within 1e6 m of the target'),
    'm/s': (1e3, 'a relative speed: the chaser starts within 1000 m/s of the target'),
}


def _text(x):
    """A bound as range text: 1e9 as '1e9', 6.3 as '6.3'."""
    return f'{x:g}'.replace('e+0', 'e').replace('e+', 'e')


def _with_unit_bounds(node, name=''):
    """``node`` with every number field of a UNIT_BOUNDS unit whose range has no upper bound bounded by it (its lower
    bound kept, or minus the bound when it has none), the reason appended to its range violations."""
    if isinstance(node, Section):
        return dataclasses.replace(node, fields={k: _with_unit_bounds(v, k) for k, v in node.fields.items()})
    if isinstance(node, ListOf):
        return dataclasses.replace(node, item=_with_unit_bounds(node.item))
    bound = UNIT_BOUNDS.get(unit_of(name))
    old = node._range
    if bound is None or node.kind not in (FLOAT, VEC3, FLOAT_LIST) or (old is not None and old.hi < math.inf):
        return node
    hi, why = bound
    if old is None or old.lo == -math.inf:
        text = f'[-{_text(hi)}, {_text(hi)}]'
    else:
        text = f'{"[" if old.lo_closed else "("}{_text(old.lo)}, {_text(hi)}]'
    return dataclasses.replace(node, range=text, why=node.why or why)


# --------------------------------------------------------------------------------------------------
# THE SCHEMA. One line per key; the keys of a UNIT_BOUNDS unit without an upper bound get that unit's.

_VEC0 = (0.0, 0.0, 0.0)
_FEEDBACK_WHY = 'a feedback frequency: faster than 100 rad/s no sensor of at most 1000 Hz lets it follow'
_ORBIT_WHY = ('the orbit radius must be above the Earth\'s equatorial radius; beyond the Moon\'s orbit it is no '
              'relative-motion problem about a planet')


def _initial_attitude(body, desc, optional=False):
    """The initial attitude of a body frame in hill, in one of three forms (the target's and the chaser's)."""
    return Section(
        desc=desc, optional=optional,
        one_of=(('q_hill_from_body', 'rpy_rad', 'body_axis_along_hill'),), fields={
            'q_hill_from_body': Field(QUAT, REQUIRED, None,
                                      'Quaternion [x, y, z, w] taking body to hill components; '
                                      'normalized on load, must be nonzero.', check=check_direction),
            'rpy_rad': Field(VEC3, REQUIRED, None,
                             '[roll, pitch, yaw]: R_hill_from_body = Rz(yaw) Ry(pitch) Rx(roll).'),
            'body_axis_along_hill': Section(
                desc='The minimal rotation taking the body axis onto the hill direction', fields={
                    'body': Field(VEC3, REQUIRED, None, 'A body-frame direction (nonzero).',
                                  check=check_direction),
                    'hill': Field(VEC3, REQUIRED, None, 'The hill-frame direction it points along (nonzero).',
                                  check=check_direction),
                }),
        })


def _initial_rate(body, desc, optional=False):
    """The initial inertial angular velocity of a body, in its own or in hill axes (target and chaser)."""
    return Section(
        desc=desc + ' (at most one turn a second)', optional=optional,
        one_of=(('omega_body_deg_s', 'omega_body_rad_s', 'omega_hill_deg_s', 'omega_hill_rad_s'),),
        fields={
            'omega_body_deg_s': Field(VEC3, REQUIRED, None, f'In {body} axes.'),
            'omega_body_rad_s': Field(VEC3, REQUIRED, None, f'In {body} axes.'),
            'omega_hill_deg_s': Field(VEC3, REQUIRED, None, 'In hill axes at t = 0.'),
            'omega_hill_rad_s': Field(VEC3, REQUIRED, None, 'In hill axes at t = 0.'),
        })

SCHEMA = _with_unit_bounds(Section(desc='A flyby scenario', fields={
    'name': Field(STR, REQUIRED, desc='Short identifier of the scenario.', check=check_nonempty),
    'description': Field(STR, '', desc='Free text.'),
    'seed': Field(INT, REQUIRED, f'[0, {SEED_MAX}]', 'Seed of every random generator of the run.',
                  why='a seed is one 32-bit word, as every seed of the command lines and campaigns'),

    'orbit': Section(desc='Circular orbit of the target', one_of=(('radius_m', 'altitude_m'),), fields={
        'radius_m': Field(FLOAT, REQUIRED, f'(0, {_text(MAX_ORBIT_RADIUS_M)}]',
                          'Orbit radius (give this or altitude_m); above the Earth\'s equatorial radius.',
                          why=_ORBIT_WHY),
        'altitude_m': Field(FLOAT, REQUIRED, f'(0, {_text(MAX_ORBIT_RADIUS_M)}]', why=_ORBIT_WHY, desc=
                            f'Altitude above the equatorial radius {EARTH_RADIUS_M} m (give this or radius_m).'),
        'mu_m3_s2': Field(FLOAT, MU_EARTH_M3_S2, '> 0', 'Gravitational parameter of the central body, '
                                                             'within [1e10, 1e18] (a moon or a planet).'),
    }),

    'target': Section(desc='The tumbling satellite', fields={
        'mass_kg': Field(FLOAT, REQUIRED, '> 0', 'Target mass, within [0.1, 1e6] kg.'),
        'inertia_kg_m2': Field(MAT3, REQUIRED, None,
                               'Inertia about the CoM in body axes; symmetric positive definite, '
                               'principal moments satisfy the triangle inequality and lie within 1e-3 to 1e3 '
                               'times mass_kg L^2 / 12 (L the largest extent of the geometry).',
                               check=check_inertia),
        'initial_attitude': _initial_attitude('target_body', 'Attitude of target_body in hill at t = 0; required '
                                                             'unless post_capture.start is attached (then derived '
                                                             'from the chaser\'s and post_capture.attachment)',
                                              optional=True),
        'initial_rate': _initial_rate('target_body',
                                      'Inertial angular velocity of the target at t = 0, in body or in hill axes; '
                                      'required unless post_capture.start is attached (then the chaser\'s)',
                                      optional=True),
        'geometry': ListOf(
            desc='Body-frame boxes making up the target shape (keep-out, markers)',
            check=check_unique_names,
            item=Section(desc='One box', fields={
                'name': Field(STR, REQUIRED, None, 'Unique box name (marker namespace).', check=check_nonempty),
                'center_m': Field(VEC3, REQUIRED, None, 'Box centre in target_body (within +-1000 m per axis).'),
                'size_m': Field(VEC3, REQUIRED, '> 0', 'Edge lengths along body x, y, z (at most 1000 m).'),
            })),
        'grasp_point_body_m': Field(VEC3, REQUIRED, None, 'Grasp point in target_body, on the surface of the '
                                                           'geometry (within 0.1 m of a face, not inside a box).'),
    }),

    'chaser': Section(desc='The servicing robot', fields={
        'mass_kg': Field(FLOAT, REQUIRED, '> 0', 'Chaser wet mass at t = 0, within [0.1, 1e6] kg.'),
        'envelope_radius_m': Field(FLOAT, REQUIRED, '> 0', 'Radius of the sphere enclosing the chaser, '
                                                                'within [0.01, 100] m.'),
        'initial_position_hill_m': Field(VEC3, REQUIRED, None, 'Chaser CoM in hill at t = 0, outside the '
                                                                 'target geometry by more than envelope_radius_m, '
                                                                 'at most 1e6 m from the target CoM.'),
        'initial_velocity_hill_mps': Field(VEC3, _VEC0, None,
                                           'Chaser velocity relative to the rotating hill frame at t = 0 '
                                           '(at most 1000 m/s).'),
        'model': Field(ENUM, 'point_mass', None,
                       'point_mass: a point receiving impulses along any direction; rigid_body: attitude, '
                       'body-fixed thrusters and reaction wheels (docs/chaser_6dof.md). The keys marked '
                       '(rigid_body) are validated in both and used only by rigid_body.',
                       choices=('point_mass', 'rigid_body')),
        'inertia_kg_m2': Field(MAT3, None, None,
                               '(rigid_body) Inertia about the CoM in chaser_body axes, wheels\' spin-axis inertia '
                               'left out; as target.inertia_kg_m2. Omitted: a uniform sphere filling the envelope, '
                               '0.4 mass_kg envelope_radius_m^2 per axis (10 kg m^2 for 100 kg, 0.5 m). Principal '
                               'moments within 1e-3 to 1e3 times mass_kg (2 envelope_radius_m)^2 / 12.',
                               check=check_inertia),
        'initial_attitude': _initial_attitude(
            'chaser_body', '(rigid_body) Attitude of chaser_body in hill at t = 0, as target.initial_attitude; '
                           'omitted: body +x at the target CoM (body_axis_along_hill, body [1, 0, 0], hill '
                           '-initial_position_hill_m)', optional=True),
        'initial_rate': _initial_rate(
            'chaser_body', '(rigid_body) Inertial angular velocity of the chaser at t = 0, as target.initial_rate; '
                           'omitted: zero (at rest in inertial space)', optional=True),
        'thrusters': Section(desc='Thrusters', fields={
            'max_thrust_n': Field(FLOAT, REQUIRED, '> 0',
                                  'Maximum thrust along any direction (point_mass); of each thruster (rigid_body).'),
            'isp_s': Field(FLOAT, REQUIRED, '> 0', 'Specific impulse (fuel use).'),
            'min_impulse_bit_ns': Field(FLOAT, 0.0, '>= 0', 'Smallest impulse the thrusters can give.'),
            'max_delta_v_per_maneuver_mps': Field(FLOAT, REQUIRED, '> 0', 'Largest single delta-v.'),
            'magnitude_error_sigma': Field(FLOAT, 0.0, '[0, 0.5]',
                                           'Relative 1-sigma error of the delta-v magnitude (point_mass, per '
                                           'maneuver); of each thruster\'s thrust (rigid_body, per run).'),
            'direction_error_sigma_deg': Field(FLOAT, 0.0, '[0, 30]',
                                               '1-sigma pointing error of the delta-v (point_mass, per maneuver); '
                                               'misalignment of each thruster about each axis (rigid_body, per '
                                               'run).'),
            'layout': ListOf(
                desc='(rigid_body) Body-fixed thrusters, each of max_thrust_n; must span every force and torque '
                     'positively; omitted: the default 12-thruster layout of docs/chaser_6dof.md',
                optional=True,
                item=Section(desc='One thruster', fields={
                    'position_m': Field(VEC3, REQUIRED, None, 'Position in chaser_body from the CoM (within 10 '
                                                                'envelope_radius_m).'),
                    'direction': Field(VEC3, REQUIRED, None,
                                       'Direction it pushes the chaser, chaser_body (nonzero; normalized on load).',
                                       check=check_direction),
                })),
        }),
        'wheels': Section(desc='(rigid_body) Reaction-wheel assembly', fields={
            'axes': Field(VEC3_LIST, ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)), None,
                          'Spin axis of each wheel in chaser_body (nonzero; normalized on load); '
                          'together they span 3 axes.',
                          check=check_direction_rows),
            'max_torque_n_m': Field(FLOAT, 0.1, '> 0', 'Motor torque limit of each wheel.'),
            'max_momentum_n_m_s': Field(FLOAT, 4.0, '> 0', 'Axial angular momentum limit of each wheel (its speed '
                                                           'limit).'),
            'spin_inertia_kg_m2': Field(FLOAT, 0.01, '> 0', 'Spin-axis inertia of each wheel.'),
            'tachometer_sigma_rad_s': Field(FLOAT, 0.01, '> 0', "1-sigma noise of each wheel's tachometer (its "
                                                               'speed relative to the body), sampled with the IMU.'),
            'initial_momentum_n_m_s': Field(FLOAT_LIST, None, None,
                                            'Axial angular momentum of each wheel at t = 0 (one per axis, within '
                                            'max_momentum_n_m_s); omitted: zero.'),
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
        'chaser_imu': Section(desc='(rigid_body) Star tracker, gyro and accelerometer of the chaser '
                                   '(docs/chaser_6dof.md)', fields={
            'rate_hz': Field(FLOAT, 10.0, '(0, 1000]', 'Gyro and accelerometer sample rate (<= 1/simulation.step_s).'),
            'star_tracker_rate_hz': Field(FLOAT, 2.0, '(0, 1000]',
                                          'Star-tracker sample rate; rate_hz must be a whole multiple of it.'),
            'star_tracker_sigma_deg': Field(FLOAT, 0.01, '[0, 180]',
                                            '1-sigma attitude error per body axis (body-frame rotation vector).'),
            'gyro_noise_sigma_rad_s': Field(FLOAT, 1e-5, '>= 0', '1-sigma white rate noise per axis and sample.'),
            'gyro_bias_sigma_rad_s': Field(FLOAT, 1e-4, '>= 0', '1-sigma of the initial gyro bias per axis.'),
            'gyro_bias_walk_rad_s_sqrt_s': Field(FLOAT, 1e-7, '>= 0',
                                                 'Bias random walk: sigma sqrt(dt) per axis between samples.'),
            'accel_noise_sigma_mps2': Field(FLOAT, 1e-4, '>= 0',
                                            '1-sigma white specific-force noise per axis and sample.'),
        }),
    }),

    'estimation': Section(desc='Target motion estimation and chaser relative navigation', fields={
        'gate_probability': Field(FLOAT, 0.9999, '(0, 1)',
                                  'Chi-square(3) probability of the innovation gate of both filters.'),
        'convergence_attitude_3sigma_deg': Field(FLOAT, 1.0, '> 0',
                                                 'Target estimate converged when its 3-sigma attitude bound '
                                                 'is below this.'),
        'convergence_rate_3sigma_deg_s': Field(FLOAT, 0.05, '> 0', '... and its 3-sigma rate bound below this.'),
        'spin_rate_deg_s': Field(FLOAT, 18.0, '> 0',
                                 'Category IV (spinning) at and above this inertial rate (20 s period).'),
        'hill_fixed_rate_deg_s': Field(FLOAT, 0.1, '> 0',
                                       'Rate relative to hill below which the attitude counts as held '
                                       'in hill (I, II).'),
        'inertial_hold_rate_deg_s': Field(FLOAT, 0.01, '> 0',
                                          'Inertial rate below which the target counts as held in inertial space (I).'),
        'controlled_rate_deg_s': Field(FLOAT, 0.01, '> 0',
                                       'Hill-relative rate below which a hill-held target is three-axis controlled '
                                       '(I), not librating (II).'),
        'controlled_excursion_deg': Field(FLOAT, 2.0, '> 0', 'Largest attitude excursion in hill for category I.'),
        'initial_rate_sigma_deg_s': Field(FLOAT, 20.0, '> 0', 'Prior 1-sigma per axis of the unknown target rate.'),
        'batch_check_max_samples': Field(INT, 2000, '[3, 1000000]', why='the fit costs about 10 ms a sample: a '
                                                                        'million is hours', desc=
                                         'The estimator checks the target filter against the batch maximum-'
                                         'likelihood fit of its measurements at convergence if there are at most '
                                         'this many (the fit costs about 10 ms a sample on a fast tumbler).'),
        'torque_psd_n2m2s': Field(FLOAT, 1e-10, '>= 0',
                                  'Torque-noise spectral density of the target filter per body axis.'),
        'accel_psd_m2_s3': Field(FLOAT, 1e-9, '>= 0',
                                 'White-acceleration spectral density of the chaser navigation filter.'),
        'initial_velocity_sigma_mps': Field(FLOAT, 0.1, '> 0', 'Prior 1-sigma per axis of the chaser velocity.'),
        'injected_rate_error_deg_s': Field(VEC3, _VEC0, None,
                                           'Fault injection: added to the published target body rate (body axes).'),
    }),

    'planner': Section(
        desc='Capture planning (seed 000 section 4); condition (a) uses estimation.spin_rate_deg_s', fields={
        'offset_m': Field(FLOAT, 1.0, '> 0', 'Preferred offset delta r of the fly-by target point from the grasp '
                                              'point (<= chaser reach less its position tolerance).'),
        'offset_min_m': Field(FLOAT, 0.6, '> 0', 'Least offset searched (offset_m if that is less).'),
        'offset_max_m': Field(FLOAT, None, '> 0', 'Largest offset searched; omitted: the manipulator reach less its '
                                                  'position tolerance.'),
        'flyby_duration_s': Field(FLOAT, 300.0, '> 0', 'Preferred time from the fly-by initial point to the grasp.'),
        'flyby_duration_max_s': Field(FLOAT, 900.0, '> 0',
                                      'Longest fly-by searched (1, 1.5, 2 and 3 times flyby_duration_s up to this).'),
        'restriction_sphere_radius_m': Field(FLOAT, 15.0, '> 0', 'No thrusting inside this sphere about the target.'),
        'clearance_margin_m': Field(FLOAT, 0.1, '>= 0',
                                    'Least gap between the chaser envelope and the swept keep-out region on the '
                                    'passive path.'),
        'reaim_check': Field(BOOL, True, None,
                             'Also keep the margin on the arc guidance will fly once it re-aims at the grasp '
                             'solved from later estimates, with the plan estimate moved 3 sigma of its published '
                             'covariance (flyby.reaim.ReaimModel; a plan without that covariance, from the truth, '
                             'has no re-aim check). Why it is on: docs/campaigns.md.'),
        'escape_check_orbits': Field(FLOAT, 1.0, '>= 1',
                                     'Length of the passive escape checked after the grasp, in orbits.'),
        'geometry_window_s': Field(FLOAT, 300.0, '>= 0',
                                   'Within this of the grasp the passive path is checked against the predicted '
                                   'target geometry (elsewhere the swept region).'),
        'geometry_attitude_margin_deg': Field(FLOAT, 2.0, '>= 0',
                                              'Attitude uncertainty of the predicted geometry at the grasp.'),
        'geometry_rate_margin_deg_s': Field(FLOAT, 0.02, '>= 0',
                                            '... growing by this rate uncertainty away from the grasp.'),
        'min_spin_axis_angle_from_orbit_normal_deg': Field(FLOAT, 10.0, '[0, 90)',
                                                           'Condition (b): spin axis at least this far from hill y '
                                                           '(no pure out-of-plane motion).'),
        'sun_direction_hill': Field(VEC3, None, None,
                                    'Condition (c): sun direction in hill at t = 0 (inertially fixed); omitted: '
                                    'lighting not checked.', check=check_direction),
        'max_sun_angle_from_grasp_velocity_deg': Field(FLOAT, 100.0, '(0, 180]',
                                                       'Condition (c): angle between the grasp velocity and the '
                                                       'sun at most this.'),
        'min_observation_s': Field(FLOAT, 60.0, '>= 0',
                                   'Plan no earlier than this after the first target measurement '
                                   '(and with a converged estimate).'),
        'maneuver_lead_s': Field(FLOAT, 10.0, '> 0', 'Time from the plan to the first terminal-approach burn.'),
        'transfer_min_s': Field(FLOAT, 150.0, '> 0',
                                'Shortest terminal transfer (first burn to the fly-by initial point).'),
        'transfer_max_s': Field(FLOAT, 450.0, '> 0',
                                'Longest terminal transfer; with transfer_min_s it sets the grasp-time search window.'),
        'delta_v_tie_mps': Field(FLOAT, 0.001, '>= 0',
                                 'Plans within this total delta-v of the cheapest tie; the larger clearance wins.'),
        'method': Field(ENUM, 'auto', None,
                        'Capture method (DESIGN §10): flyby (seed 000), optimal (seed 003 section 4, rigid_body '
                        'only), sync (seed 001 section 2, rigid_body only) or auto (sync for category IV, else the '
                        'fly-by where a safe one exists, else optimal; sync and optimal with a rigid_body chaser).',
                        choices=('flyby', 'optimal', 'sync', 'auto')),
        'optimal': Section(desc='The optimization-based approach (seed 003 section 4, docs/optimal.md)', fields={
            'plume_radius_m': Field(FLOAT, 5.0, '>= 0',
                                    'Within this of the target CoM no thrust away from the target (its exhaust '
                                    'toward it), seed 003 metric 4 as a rule.'),
            'accel_max_mps2': Field(FLOAT, None, '> 0', 'Largest thrust acceleration flown (plan and feedback); '
                                                        'omitted: chaser.thrusters.max_thrust_n / mass_kg.'),
            'feedback_share': Field(FLOAT, 0.1, '[0, 1)',
                                    'Share of accel_max_mps2 kept for the tracking feedback; the plan uses the rest.'),
            'approach_time_s': Field(FLOAT, None, '> 0', 'Approach time T from the start to the grasp; omitted: '
                                                         'chosen by eq 5 within the two bounds below.'),
            'approach_time_min_s': Field(FLOAT, 20.0, '> 0', 'Shortest approach time searched.'),
            'approach_time_max_s': Field(FLOAT, 200.0, '> 0', 'Longest approach time searched.'),
            'weight_actuator': Field(FLOAT, 1000.0, '>= 0', 'k_a of eq 5 [1/s].'),
            'weight_fuel': Field(FLOAT, 10.0, '>= 0', 'k_f of eq 5 [1/kg] (on the fuel rate).'),
            'weight_safety': Field(FLOAT, 1.0, '>= 0', 'k_s of eq 5 [s/m].'),
            'weight_plume': Field(FLOAT, 100.0, '>= 0', 'k_pi of eq 5 [s/m].'),
            'weight_time': Field(FLOAT, 0.001, '>= 0', 'k_t of eq 5 [1/s^2].'),
            'trajectory_step_s': Field(FLOAT, 0.2, '> 0', 'Largest spacing of the points of planner/trajectory '
                                                          '(they fall on the plan\'s thrust steps).'),
            'tracking_frequency_rad_s': Field(FLOAT, 0.5, '(0, 100]',
                                              'Natural frequency of the tracking feedback (critically damped).',
                                              why=_FEEDBACK_WHY),
            'replan_error_m': Field(FLOAT, 0.5, '> 0',
                                    'Re-plan when the estimated position leaves the trajectory by more than this.'),
            'replan_cutoff_s': Field(FLOAT, 15.0, '>= 0', 'No re-plan in the last this many seconds before the '
                                                          'grasp (the capture decision judges the arrival).'),
            'reaim_interval_s': Field(FLOAT, 10.0, '> 0', 'Every this many seconds of the approach the end point '
                                                          'X_Ft is predicted again from the newest target estimate'),
            'reaim_error_m': Field(FLOAT, 0.02, '> 0', 'Re-plan to the new X_Ft when it moved by more than this '
                                                       '(outside the last replan_cutoff_s).'),
        }),
        'sync': Section(desc='The synchronized approach (seed 001 section 2, docs/synchronized.md); the docking port '
                             'is target.grasp_point_body_m, the final range planner.offset_m', fields={
            'station_range_m': Field(FLOAT, 5.0, '> 0', 'Station point of stages 2-3 on the port\'s outward line, '
                                                        'from the target CoM (seed 001: 5 m).'),
            'arrival_start_s': Field(FLOAT, 260.0, '>= 0', 'Window (t_s_opt, t_f_opt) of the arrival at the station, '
                                                           'mission time: its start (seed 001 Table 1) ...'),
            'arrival_end_s': Field(FLOAT, 370.0, '> 0', '... and its end.'),
            'min_transfer_s': Field(FLOAT, 150.0, '> 0', 'A plan made later than this before the window\'s start '
                                                         '(a late estimate) moves the window to start this long after '
                                                         'the plan\'s start, its length kept.'),
            'keepout_margin_m': Field(FLOAT, 0.1, '>= 0', 'Stage 1 keeps the chaser envelope this far outside the '
                                                          'target geometry\'s bounding sphere.'),
            'trajectory_step_s': Field(FLOAT, 0.5, '> 0', 'Spacing of the points of planner/trajectory.'),
            'resolve_interval_s': Field(FLOAT, 30.0, '> 0', 'Stage 1 is re-solved from the newest estimates this '
                                                            'often (the solution closest to the previous one).'),
            'resolve_cutoff_s': Field(FLOAT, 60.0, '>= 0', 'The last re-solve this long before the arrival (they '
                                                          'come every resolve_interval_s, or halfway to the '
                                                          'arrival when that is sooner).'),
            'resolve_lead_s': Field(FLOAT, 10.0, '> 0', 'A re-solve\'s link starts this long after its plan time '
                                                        '(the first plan\'s maneuver_lead_s after).'),
            'docking_duration_s': Field(FLOAT, 40.0, '> 0', 'Stage 4, from the station range to the final range.'),
            'orbiting_fraction': Field(FLOAT, 0.5, '>= 0', 'Stage 3 lasts this fraction of a rotation cycle '
                                                          '2 pi / |omega| (seed 001: half).'),
            'accel_max_mps2': Field(FLOAT, None, '> 0', 'Largest commanded thrust acceleration; omitted: two '
                                                        'thrusters\' max_thrust_n / mass_kg.'),
            'tracking_frequency_rad_s': Field(FLOAT, 1.0, '(0, 100]', 'Natural frequency of the translation '
                                                                       'feedback (critically damped).',
                                              why=_FEEDBACK_WHY),
            'attitude_tolerance_deg': Field(FLOAT, 0.2, '> 0', 'Stage 2 ends when the estimated relative attitude '
                                                               'error ...'),
            'rate_tolerance_deg_s': Field(FLOAT, 0.1, '> 0', '... and rate error stay below these ...'),
            'settle_s': Field(FLOAT, 2.0, '>= 0', '... for this long.'),
            'attitude_sync_max_s': Field(FLOAT, 60.0, '> 0', 'Stage 2 not done this long after the arrival is a '
                                                             'fault: guidance retreats and the mission aborts.'),
            'retreat_speed_mps': Field(FLOAT, 0.3, '> 0', 'After an abort the chaser thrusts outward along the '
                                                          'port\'s direction until this outward speed ...'),
            'retreat_max_s': Field(FLOAT, 10.0, '> 0', '... or for at most this long, then drifts.'),
        }),
    }),

    'guidance': Section(desc='Terminal approach and trajectory adjusting', fields={
        'adjust_interval_s': Field(FLOAT, 20.0, '> 0', 'Cadence of trajectory-adjusting maneuvers.'),
        'midcourse_corrections': Field(INT, 1, '[0, 100]', why='each is a burn: a hundred in one transfer already '
                                                               'come seconds apart', desc=
                                       'CW re-solves (eq 28) spread evenly over the terminal transfer.'),
        'command_lead_s': Field(FLOAT, 5.0, '> 0',
                                'A burn is computed from the latest estimate and sent this long before it starts.'),
        'deadband_mps': Field(FLOAT, 0.0002, '>= 0',
                              'Adjusting burns smaller than this (or the minimum impulse bit) are skipped.'),
        'adjust_position_tolerance_m': Field(FLOAT, 0.005, '> 0',
                                             'Predicted miss at the fly-by target point small enough to '
                                             'stop adjusting ...'),
        'adjust_velocity_tolerance_mps': Field(FLOAT, 0.0005, '> 0', '... together with this velocity miss.'),
        'sphere_margin_m': Field(FLOAT, 1.0, '>= 0',
                                 'No burn whose predicted arc comes within this of the restriction sphere.'),
        'adjust_law': Field(ENUM, 'arc', None, 'Trajectory adjusting: onto the passive arc through the fly-by target '
                                               'point (arc), or seed 000 eq 24-26 least squares (eq26).',
                            choices=('arc', 'eq26')),
        'arc_rendezvous_lead_s': Field(FLOAT, 40.0, '>= 0',
                                       'The arc law puts the chaser back on the passive arc (position and velocity) '
                                       'this long before its last burn outside the sphere; the burns after only '
                                       'trim.'),
        'refine_target': Field(BOOL, True, None,
                               'Re-aim each adjusting burn at the grasp re-solved from the latest target estimate.'),
        'momentum_dump_start_n_m_s': Field(FLOAT, 1.0, '> 0',
                                           '(rigid_body) The wheels\' momentum above which the attitude guidance '
                                           'dumps it by thruster couples, outside the restriction sphere ...'),
        'momentum_dump_stop_n_m_s': Field(FLOAT, 0.2, '>= 0', '... down to this on each body axis (below the '
                                                              'start).'),
    }),

    'supervisor': Section(desc='Mission phases, capture decision, watchdog and abort', fields={
        'capture_hold_s': Field(FLOAT, 10.0, '>= 0', 'Time attached to the target before COMPLETE.'),
        'watchdog_s': Field(FLOAT, 5.0, '> 0',
                            'A node silent this long (sim time) is lost: the fault table answers (docs/faults.md).'),
        'hold_limit_s': Field(FLOAT, 600.0, '> 0',
                              'A hold or a retreat (the fault table\'s answers that wait for a fault\'s recovery: '
                              'docs/faults.md) whose faults have not all recovered this long after it began aborts.'),
        'max_retreats': Field(INT, 1, '[0, 10]', why='each retry flies an approach again: ten already span hours',
                              desc='Approaches given up by a retreat and flown again at most; the fault table\'s '
                                   'retreat beyond them aborts.'),
        'abort_observation_s': Field(FLOAT, 60.0, '>= 0',
                                     'The run goes on this long after ABORTED, to record the escape.'),
        'avoidance_delta_v_mps': Field(FLOAT, 0.05, '> 0',
                                       'Size of the collision-avoidance burn an abort outside the restriction sphere '
                                       'may fire.'),
    }),

    'post_capture': Section(
        desc='After the capture (seed 000 section 2.2 phases (5)-(6), seed 004 section 2.2; rigid_body only, '
             'docs/post_capture.md): the grasp, the damping of the combined body and the estimation of the target\'s '
             'mass properties; omitted: the capture ends the run supervisor.capture_hold_s later',
        optional=True, fields={
            'start': Field(ENUM, 'capture', None,
                           'capture: the phases follow a capture (GRASP, DAMPING, MASS_ESTIMATION); attached: the '
                           'run starts with the chaser holding the target as one rigid body (seed 004 section 3.1) '
                           'and goes straight to MASS_ESTIMATION, on the body as it turns.',
                           choices=('capture', 'attached')),
            'attachment': Section(desc='(start attached) How the chaser holds the target from t = 0', optional=True,
                                  fields={
                'target_com_chaser_body_m': Field(VEC3, REQUIRED, None,
                                                  'X_s: the target\'s CoM from the chaser\'s CoM, chaser_body axes '
                                                  '(seed 004 Table 1 "center of mass").'),
                'target_rpy_in_chaser_rad': Field(VEC3, _VEC0, None,
                                                  'Attitude of target_body in chaser_body, [roll, pitch, yaw]: '
                                                  'R_chaser_from_target = Rz(yaw) Ry(pitch) Rx(roll) (seed 004 '
                                                  'Table 1 "attitude angles").'),
            }),
            'grasp': Section(desc='The arm: an impedance between its end effector and the grasp point '
                                  '(flyby_sim.dynamics.grasp)', fields={
                'stiffness_n_per_m': Field(FLOAT, 200.0, '> 0', 'Translational stiffness K_p.'),
                'damping_n_s_per_m': Field(FLOAT, 150.0, '> 0', 'Translational damping D_p.'),
                'rot_stiffness_n_m_per_rad': Field(FLOAT, 50.0, '> 0', 'Rotational stiffness K_r.'),
                'rot_damping_n_m_s_per_rad': Field(FLOAT, 40.0, '> 0', 'Rotational damping D_r.'),
                'max_force_n': Field(FLOAT, 50.0, '> 0', 'The gripper lets go above this contact force ...'),
                'max_torque_n_m': Field(FLOAT, 20.0, '> 0', '... or this contact torque ...'),
                'max_stroke_m': Field(FLOAT, 0.2, '> 0', '... or when the grasp point leaves this compliance stroke.'),
                'velocity_tolerance_mps': Field(FLOAT, 0.001, '> 0', 'The relative motion is damped (the arm locks: '
                                                                     'one rigid body) once the grasp point\'s '
                                                                     'relative velocity ...'),
                'rate_tolerance_rad_s': Field(FLOAT, 0.001, '> 0', '... and the relative rate stay below these.'),
                'max_duration_s': Field(FLOAT, 20.0, '> 0', 'The arm locks at the latest this long after the '
                                                            'first contact.'),
            }),
            'damping': Section(desc='Detumbling of the combined body by rate feedback on the thrusters and wheels '
                                    '(flyby_guidance.damping)', fields={
                'momentum_threshold_kg_m2_s': Field(FLOAT, 0.1, '> 0',
                                                    'Damped when the estimated angular momentum (prior inertia) '
                                                    'stays below this (seed 004 section 3.2) ...'),
                'settle_s': Field(FLOAT, 5.0, '>= 0', '... for this long (its mean over this window).'),
                'inertia_lower_bound_kg_m2': Field(FLOAT, None, '> 0',
                                                   'Lower bound of the combined body\'s principal moments that sets '
                                                   'the gains (I_lb / (2 T), T the IMU period); omitted: half the '
                                                   'smallest principal moment of target.inertia_kg_m2.'),
                'wheel_share': Field(FLOAT, 0.1, '(0, 1)', 'Share of the rate gain on the wheels.'),
                'max_thruster_torque_n_m': Field(FLOAT, 2.0, '> 0', 'Saturation of the thrusters\' couple per '
                                                                    'body axis.'),
                'dump_rate_per_s': Field(FLOAT, 0.05, '> 0', 'Rate at which the wheels\' momentum is handed to the '
                                                             'thrusters.'),
            }),
            'mass_estimation': Section(desc='The target\'s mass properties from known thruster firings (seed 004 '
                                            'section 2.2, flyby_estimation.mass_properties)', fields={
                'excitation': Field(ENUM, 'table1', None,
                                    'table1: seed 004 Table 1\'s sequence (30 N s); chosen: the sequence chosen for '
                                    'observability at no more impulse (docs/post_capture.md).',
                                    choices=('table1', 'chosen')),
                'start_delay_s': Field(FLOAT, 2.0, '>= 0', 'From the end of the damping to the excitation\'s start.'),
                'window_s': Field(FLOAT, 25.0, '[20, 600]', 'The estimate is final this long after the excitation\'s '
                                                            'start (both sequences end within 20 s).'),
                'prior_mass_sigma': Field(FLOAT, 0.025, '(0, 0.5)',
                                          'Relative 1-sigma of the prior target mass, drawn around target.mass_kg '
                                          'from the seed (a catalogue value).'),
                'prior_moments_sigma': Field(FLOAT, 0.03, '(0, 0.5)',
                                             'Relative 1-sigma of the prior principal moments, drawn likewise around '
                                             'those of target.inertia_kg_m2.'),
                'prior_com_sigma_m': Field(FLOAT, 0.02, '> 0', '1-sigma per axis of the prior target CoM (the '
                                                               'navigation estimate at the capture).'),
                'prior_axes_sigma_deg': Field(FLOAT, None, '> 0',
                                              '1-sigma per axis of the prior principal axes (the target attitude '
                                              'estimate at the capture); omitted: that estimate\'s own, the largest '
                                              'of its attitude covariance.'),
            }),
            'transport': Section(desc='(optional) After the mass estimation, the combined body moved to a goal on the '
                                      'reference orbit by the tug\'s thrusters (seed 004 sections 2.3, 3.2; '
                                      'docs/transport.md); omitted: the run completes after the estimation',
                                 optional=True, fields={
                'goal_hill_m': Field(VEC3, REQUIRED, None,
                                     'Goal of the combined body\'s CoM, hill [m] (a point fixed on the reference '
                                     'orbit, e.g. [1000, 0, 0]: 1 km ahead on V-bar).'),
                'transfer_time_s': Field(FLOAT, REQUIRED, '> 0', 'From the start of TRANSPORT to the arrival at the '
                                                                 'goal.'),
                'plume_cone_deg': Field(FLOAT, 60.0, '[0, 90)',
                                        'A thruster whose exhaust points within this half-angle of the target\'s '
                                        'CoM is not fired in transport (its plume would hit what the tug holds): '
                                        'the thrusters are direction-limited.'),
                'replan_interval_s': Field(FLOAT, 20.0, '> 0', 'After the last push guidance solves the terminal '
                                                               'program again from the latest estimate this often '
                                                               '(docs/transport.md).'),
                'hold_s': Field(FLOAT, 60.0, '>= 0', 'The three conditions, judged from the estimate with its '
                                                     '3-sigma, must hold this long before TRANSPORT -> COMPLETE.'),
                'wheel_momentum_share': Field(FLOAT, 0.5, '(0, 1]', 'At the end the wheels hold at most this share '
                                                                    'of their momentum capacity.'),
                'max_angular_momentum_kg_m2_s': Field(FLOAT, 0.1, '> 0', 'Rendezvous condition 1 (seed 004 '
                                                                         'section 3.2).'),
                'max_position_error_m': Field(FLOAT, 10.0, '> 0', 'Rendezvous condition 2.'),
                'max_momentum_error_n_s': Field(FLOAT, 0.01, '> 0',
                                                'Rendezvous condition 3: the paper\'s "orbital momentum" error '
                                                '0.01 N m s read as the body\'s linear momentum relative to the '
                                                'goal\'s circular motion, m |v_hill| [N s].'),
            }),
        }),

    'simulation': Section(desc='Plant integration', fields={
        'dynamics': Field(ENUM, 'nonlinear', None, 'Relative orbital dynamics: nonlinear two-body or linear CW.',
                          choices=('cw', 'nonlinear')),
        'step_s': Field(FLOAT, MAX_STEP_S, f'[{MIN_STEP_S}, {MAX_STEP_S}]',
                        'Fixed integration step; truth is published every step.',
                        why=f'truth is published every step and must reach >= {1 / MAX_STEP_S:g} Hz, DESIGN §4; '
                            f'a finer step than {MIN_STEP_S:g} s resolves nothing more and makes the run endless'),
        'duration_s': Field(FLOAT, REQUIRED, '> 0', 'Simulated time after which the run stops; at '
                                                                  'least one step, at most 1e7 steps.'),
    }),

    'faults': FAULTS,
}))
