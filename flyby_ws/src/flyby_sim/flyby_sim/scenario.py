"""Scenario files (DESIGN §6): the flyby schema, a validating loader and a read-only Scenario.

A scenario is one YAML file. ``SCHEMA`` below names every key with its type, default (or
REQUIRED), validated range and a one-line description (the engine is ``flyby_msgs_py.schema``);
``docs/scenario.md`` embeds the table that ``schema_markdown()`` renders from it (a test keeps the
two identical). Adding a key is one line in ``SCHEMA``.

    sc = load_scenario('scenarios/paper_flyby.yaml')
    sc.chaser.thrusters.isp_s          # 220.0, defaults filled in, read-only
    sc.q_hill_from_body0               # unit quaternion (x, y, z, w), scalar last
    sc.omega_body0_rad_s               # inertial angular velocity of the target in body axes

Every problem raises ``flyby_msgs_py.schema.ScenarioError`` (a ``ValueError``) whose message is one
line naming the file, the dotted key path and the problem, e.g.
``scenarios/x.yaml: chaser.mass_kg: must be > 0, got -5.0``.

Quaternion convention: (x, y, z, w), scalar last, as ``flyby_sim.dynamics.rotation``.
``q_hill_from_body`` rotates body components into hill components: ``v_hill = R(q_hill_from_body) @ v_body``.
"""

import copy
import math
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

from flyby_msgs_py import schema
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
    Invalid,
    ListOf,
    Namespace,
    ScenarioError,
    Section,
    check_nonempty,
    check_nonzero,
    format_floats,
    load_yaml_mapping,
    validate,
    validate_field,
)
from flyby_sim import chasers
from flyby_sim.dynamics.actuators import ThrusterLayout, default_thruster_layout, is_positively_spanning
from flyby_sim.dynamics.constants import EARTH_RADIUS_M, MU_EARTH_M3_S2
from flyby_sim.dynamics.grasp import Impedance
from flyby_sim.dynamics.orbital import mean_motion_rad_s
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_multiply,
    quat_normalize,
    quat_rotate,
    quat_rotate_many,
    quat_shortest_arc,
)

MAX_STEP_S = 0.05  # truth is published every step and must reach >= 20 Hz (DESIGN §4)


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
        return f'must be positive definite, got principal moments {format_floats(moments)}'
    if moments[0] + moments[1] < moments[2] * (1.0 - 1e-12):
        return (f'principal moments {format_floats(moments)} violate the triangle inequality '
                f'(I1 + I2 >= I3 for any rigid body)')
    return None


def _check_unique_names(items):
    seen = {}
    for i, item in enumerate(items):
        if item['name'] in seen:
            return i, 'name', f'duplicate box name {item["name"]!r} (also at index {seen[item["name"]]})'
        seen[item['name']] = i
    return None


def _check_nonzero_rows(rows):
    for i, row in enumerate(rows):
        if not any(row):
            return f'row {i} must be nonzero, got {row}'
    return None


# --------------------------------------------------------------------------------------------------
# THE SCHEMA. One line per key.

_VEC0 = (0.0, 0.0, 0.0)


def _initial_attitude(body, desc, optional=False):
    """The initial attitude of a body frame in hill, in one of three forms (the target's and the chaser's)."""
    return Section(
        desc=desc, optional=optional,
        one_of=(('q_hill_from_body', 'rpy_rad', 'body_axis_along_hill'),), fields={
            'q_hill_from_body': Field(QUAT, REQUIRED, None,
                                      'Quaternion [x, y, z, w] taking body to hill components; '
                                      'normalized on load, must be nonzero.', check=check_nonzero),
            'rpy_rad': Field(VEC3, REQUIRED, None,
                             '[roll, pitch, yaw]: R_hill_from_body = Rz(yaw) Ry(pitch) Rx(roll).'),
            'body_axis_along_hill': Section(
                desc='The minimal rotation taking the body axis onto the hill direction', fields={
                    'body': Field(VEC3, REQUIRED, None, 'A body-frame direction (nonzero).',
                                  check=check_nonzero),
                    'hill': Field(VEC3, REQUIRED, None, 'The hill-frame direction it points along (nonzero).',
                                  check=check_nonzero),
                }),
        })


def _initial_rate(body, desc, optional=False):
    """The initial inertial angular velocity of a body, in its own or in hill axes (target and chaser)."""
    return Section(
        desc=desc, optional=optional,
        one_of=(('omega_body_deg_s', 'omega_body_rad_s', 'omega_hill_deg_s', 'omega_hill_rad_s'),),
        fields={
            'omega_body_deg_s': Field(VEC3, REQUIRED, None, f'In {body} axes.'),
            'omega_body_rad_s': Field(VEC3, REQUIRED, None, f'In {body} axes.'),
            'omega_hill_deg_s': Field(VEC3, REQUIRED, None, 'In hill axes at t = 0.'),
            'omega_hill_rad_s': Field(VEC3, REQUIRED, None, 'In hill axes at t = 0.'),
        })

SCHEMA = Section(desc='A flyby scenario', fields={
    'name': Field(STR, REQUIRED, desc='Short identifier of the scenario.', check=check_nonempty),
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
            check=_check_unique_names,
            item=Section(desc='One box', fields={
                'name': Field(STR, REQUIRED, None, 'Unique box name (marker namespace).', check=check_nonempty),
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
        'model': Field(ENUM, 'point_mass', None,
                       'point_mass: a point receiving impulses along any direction; rigid_body: attitude, '
                       'body-fixed thrusters and reaction wheels (docs/chaser_6dof.md). The keys marked '
                       '(rigid_body) are validated in both and used only by rigid_body.',
                       choices=('point_mass', 'rigid_body')),
        'inertia_kg_m2': Field(MAT3, None, None,
                               '(rigid_body) Inertia about the CoM in chaser_body axes, wheels\' spin-axis inertia '
                               'left out; as target.inertia_kg_m2. Omitted: a uniform sphere filling the envelope, '
                               '0.4 mass_kg envelope_radius_m^2 per axis (10 kg m^2 for 100 kg, 0.5 m).',
                               check=_check_inertia),
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
                    'position_m': Field(VEC3, REQUIRED, None, 'Position in chaser_body from the CoM.'),
                    'direction': Field(VEC3, REQUIRED, None,
                                       'Direction it pushes the chaser, chaser_body (nonzero; normalized on load).',
                                       check=check_nonzero),
                })),
        }),
        'wheels': Section(desc='(rigid_body) Reaction-wheel assembly', fields={
            'axes': Field(VEC3_LIST, ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)), None,
                          'Spin axis of each wheel in chaser_body (nonzero; normalized on load).',
                          check=_check_nonzero_rows),
            'max_torque_n_m': Field(FLOAT, 0.1, '> 0', 'Motor torque limit of each wheel.'),
            'max_momentum_n_m_s': Field(FLOAT, 4.0, '> 0', 'Axial angular momentum limit of each wheel (its speed '
                                                           'limit).'),
            'spin_inertia_kg_m2': Field(FLOAT, 0.01, '> 0', 'Spin-axis inertia of each wheel.'),
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
        'batch_check_max_samples': Field(INT, 2000, '>= 3',
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
        'max_unguided_coast_s': Field(FLOAT, 200.0, '> 0',
                                      'Not read: the planner bounds the coast from the last adjusting burn to the '
                                      'grasp by its predicted 3-sigma miss instead (docs/planner.md); accepted so '
                                      'that scenario files written with it still load.'),
        'clearance_margin_m': Field(FLOAT, 0.1, '>= 0',
                                    'Least gap between the chaser envelope and the swept keep-out region on the '
                                    'passive path.'),
        'reaim_check': Field(BOOL, True, None,
                             'Also keep the margin on the arc guidance will fly once it re-aims at the grasp '
                             'solved from later estimates, with the plan estimate moved 3 sigma of its published '
                             'covariance (plan._ReaimModel; a plan without that covariance, from the truth, has '
                             'no re-aim check). Off, the fourth envelope campaign flew five plans whose re-aimed '
                             'arcs crossed a panel (docs/campaigns.md).'),
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
                                    'lighting not checked.', check=check_nonzero),
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
            'tracking_frequency_rad_s': Field(FLOAT, 0.5, '> 0',
                                              'Natural frequency of the tracking feedback (critically damped).'),
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
            'tracking_frequency_rad_s': Field(FLOAT, 1.0, '> 0', 'Natural frequency of the translation feedback '
                                                                 '(critically damped).'),
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
        'midcourse_corrections': Field(INT, 1, '>= 0',
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
                            'Abort and escape when the estimator or guidance has been silent this long (sim time).'),
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
                                    '(flyby_guidance.post_capture)', fields={
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
                'replan_interval_s': Field(FLOAT, 20.0, '> 0', 'Guidance predicts the plan\'s arrival again from '
                                                               'the latest estimate this often ...'),
                'replan_position_m': Field(FLOAT, 2.0, '> 0', '... and plans again when it misses the goal by more '
                                                              'than this; after the arrival it trims an estimate off '
                                                              'the goal by more than this ...'),
                'replan_momentum_n_s': Field(FLOAT, 0.005, '> 0', '... or moving with more than this linear momentum.'),
                'settle_s': Field(FLOAT, 60.0, '>= 0', 'After the arrival: trims, then the conditions are judged '
                                                       'this long after it (TRANSPORT -> COMPLETE).'),
                'nav_accel_psd_m2_s3': Field(FLOAT, 1e-11, '> 0',
                                             'The combined body\'s navigation coasting: the white acceleration its '
                                             'filter allows for what it does not model (CW\'s linearization within '
                                             'a few km, the errors of the commanded small firings) [m^2/s^3].'),
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
        'step_s': Field(FLOAT, MAX_STEP_S, f'(0, {MAX_STEP_S}]',
                        'Fixed integration step; truth is published every step.',
                        why=f'truth is published every step and must reach >= {1 / MAX_STEP_S:g} Hz, DESIGN §4'),
        'duration_s': Field(FLOAT, REQUIRED, '> 0', 'Simulated time after which the run stops.'),
    }),
})


def _cross_checks(d):
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
    h0 = wheels['initial_momentum_n_m_s']
    if h0 is not None:
        if len(h0) != len(wheels['axes']):
            raise Invalid('chaser.wheels.initial_momentum_n_m_s',
                          f'must give one value per wheel axis ({len(wheels["axes"])}), got {len(h0)}')
        for i, h in enumerate(h0):
            if abs(h) > wheels['max_momentum_n_m_s']:
                raise Invalid(f'chaser.wheels.initial_momentum_n_m_s[{i}]',
                              f'must be within +-max_momentum_n_m_s = {wheels["max_momentum_n_m_s"]!r}, got {h!r}')


def _resolve(data, seed):
    """The resolved dict of a scenario mapping (defaults filled in, ``seed`` overriding the file's),
    checked across keys; raises Invalid."""
    resolved = validate(SCHEMA, data)
    if seed is not None:
        try:
            resolved['seed'] = validate_field(SCHEMA.fields['seed'], seed, 'seed')
        except Invalid as e:
            raise Invalid('seed', f'{e.problem} (from the seed argument)') from None
    _cross_checks(resolved)
    return resolved


# --------------------------------------------------------------------------------------------------
# The read-only result

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
        if self.post_capture is None:
            return None
        g = self.post_capture.grasp
        return Impedance(stiffness_n_m=g.stiffness_n_per_m, damping_n_s_m=g.damping_n_s_per_m,
                         rot_stiffness_n_m_rad=g.rot_stiffness_n_m_per_rad,
                         rot_damping_n_m_s_rad=g.rot_damping_n_m_s_per_rad, max_force_n=g.max_force_n,
                         max_torque_n_m=g.max_torque_n_m, max_stroke_m=g.max_stroke_m)

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


# --------------------------------------------------------------------------------------------------
# Entry points

def scenario_from_dict(data, name='<dict>', seed=None, path=None):
    """Validate a scenario mapping (as parsed from YAML) into a Scenario; ``name`` labels errors.

    With ``chasers:`` (several robots, flyby_sim.chasers) the result is the first chaser's view; every chaser's
    view is ``for_chaser(name)``."""
    if isinstance(data, dict) and 'chasers' in data:
        return _fleet_from_dict(data, name, seed, path)
    try:
        resolved = _resolve(data, seed)
    except Invalid as e:
        raise ScenarioError(name, e.key, e.problem) from None
    return Scenario(resolved, copy.deepcopy(data), path)


def _fleet_from_dict(data, name, seed, path):
    """The views of a ``chasers:`` scenario (flyby_sim.chasers), each a single-chaser Scenario; the first."""
    try:
        singles = chasers.single_chaser_dicts(data)
    except Invalid as e:
        raise ScenarioError(name, e.key, e.problem) from None
    views = []
    for chaser_name, single, i in singles:
        try:
            base_seed = _resolve(single, seed)['seed']
            resolved = _resolve(single, chasers.chaser_seed(base_seed, i))
        except Invalid as e:
            raise ScenarioError(name, chasers.entry_key(e.key, i, data), e.problem) from None
        views.append((chaser_name, Scenario(resolved, single, path)))
    fleet = tuple(views)
    for chaser_name, view in fleet:
        object.__setattr__(view, '_fleet', fleet)
        object.__setattr__(view, 'chaser_name', chaser_name)
    return fleet[0][1]


def load_scenario(path, seed=None):
    """Load and validate a scenario YAML file; ``seed`` (int >= 0) overrides the file's seed.

    Raises ScenarioError with a one-line message ``<path>: <key.path>: <problem>``.
    """
    return scenario_from_dict(load_yaml_mapping(path), name=str(path), seed=seed, path=path)


def scenario_of(node):
    """Declare the node's ``scenario_file``, ``seed`` and ``chaser`` parameters and load the scenario (seed < 0: the
    file's); with ``chaser`` (a ``chasers:`` scenario) that chaser's view."""
    node.declare_parameter('scenario_file', '')
    node.declare_parameter('seed', -1)
    node.declare_parameter('chaser', '')
    seed = node.get_parameter('seed').value
    path = node.get_parameter('scenario_file').value
    scenario = load_scenario(path, seed=None if seed < 0 else seed)
    chaser = node.get_parameter('chaser').value
    if not chaser:
        return scenario
    try:
        return scenario.for_chaser(chaser)
    except KeyError as err:
        raise ScenarioError(path, 'chasers', f'parameter chaser: {err.args[0]}') from None


def schema_markdown():
    """The key table of docs/scenario.md, rendered from SCHEMA."""
    return schema.schema_markdown(SCHEMA)


def main(argv=None):
    """``python -m flyby_sim.scenario FILE [--seed N]`` prints the resolved scenario or the error;
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
