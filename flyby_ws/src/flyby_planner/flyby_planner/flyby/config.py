"""What the fly-by planner is configured with (``PlannerConfig``: the search's bounds, margins and limits, seed 000
sections 4.3-4.5), a parameter record of the scenario, and the target's true motion for a plan from the truth.

Pure numpy, no ROS. SI units, angles in rad.
"""

import math

import numpy as np

from flyby_estimation.attitude_error_dynamics import ErrorStateDynamics
from flyby_estimation.target_motion import MotionPrediction
from flyby_msgs_py import params
from flyby_planner.flyby.uncertainty import EstimateAccuracy
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.orbital import hill_axes_in_eci, q_eci_from_body

# The searched offsets are this far apart [m]; fly-by durations are these multiples of flyby_duration_s.
_OFFSET_STEP_M = 0.2
# Half the preferred fly-by comes last: a fast grasp point's X_Fi is then nearer and its injection smaller.
_DURATION_FACTORS = (1.0, 1.5, 2.0, 3.0, 0.5)
# The grasp window holds at least this many turns of the target relative to hill; the transfer is
# kept below this fraction of an orbit (eq 28's Phi12 is singular at half an orbit, out of plane).
_WINDOW_TURNS = 2.0
_TRANSFER_CAP_ORBITS = 0.4


def _sun_direction_eci(scenario):
    """planner.sun_direction_hill turned to eci at t = 0 (inertially fixed), or None: lighting not checked."""
    p = scenario.planner
    if p.sun_direction_hill is None:
        return None
    return hill_axes_in_eci(0.0, scenario.mean_motion_rad_s) @ np.asarray(p.sun_direction_hill, dtype=float)


def _impulse_error_sigma(scenario):
    """The thrusters' 1-sigma impulse error [-]: magnitude and direction errors combined."""
    t = scenario.chaser.thrusters
    return math.hypot(t.magnitude_error_sigma, math.radians(t.direction_error_sigma_deg))


@params.record
class PlannerConfig:
    """Everything ``plan_capture`` needs besides the prediction and the chaser state: the fly-by's record.

    Attributes (SI; angles in rad): see the ``planner`` section of docs/scenario.md for the meaning
    and the seed 000 example defaults; ``boxes`` is flyby_sim.scenario.Boxes. offset_min_m is at most offset_m,
    flyby_duration_max_s at least flyby_duration_s; offset_max_m is the scenario's (the manipulator's reach less its
    position tolerance unless planner.offset_max_m says otherwise).
    accuracy (EstimateAccuracy, from the sensors and estimation sections) turns on the planner's uncertainty
    model (package doc, step 4), with the manipulator's position_tolerance_m and velocity_tolerance_mps as the bound
    on the predicted miss, guidance's adjust_interval_s and command_lead_s for the last burn; None keeps the fixed
    geometry_attitude_margin_rad + geometry_rate_margin_rad_s and no miss bound. reaim_check (with accuracy and a
    covariance passed to plan_capture): check the passage guidance flies once it re-aims at 3 sigma of the plan
    estimate's covariance (ReaimModel). A caller without the estimate's covariance (a plan from the truth) gets no
    re-aim check: the convergence bound instead is 2-5 times the filter's sigma and its motions part by more than
    REAIM_MAX_PARTING_RAD 453 s out on paper_flyby, refusing what flies (docs/campaigns.md). latest_grasp_s: the
    run's duration less the supervisor's capture hold [s].
    """

    mean_motion_rad_s: float = params.key('mean_motion_rad_s')
    orbit_radius_m: float = params.key('orbit_radius_m')
    x_grasp_body_m: np.ndarray = params.key('target.grasp_point_body_m', np.array)
    boxes: object = params.key('boxes')
    inertia_kg_m2: np.ndarray = params.key('target_inertia')
    envelope_radius_m: float = params.key('chaser.envelope_radius_m')
    offset_m: float = params.key('planner.offset_m')
    offset_min_m: float = params.derived(lambda sc: min(sc.planner.offset_min_m, sc.planner.offset_m))
    offset_max_m: float = params.key('offset_max_m')
    flyby_duration_s: float = params.key('planner.flyby_duration_s')
    flyby_duration_max_s: float = params.derived(lambda sc: max(sc.planner.flyby_duration_max_s,
                                                                sc.planner.flyby_duration_s))
    restriction_sphere_radius_m: float = params.key('planner.restriction_sphere_radius_m')
    sphere_margin_m: float = params.key('guidance.sphere_margin_m')
    clearance_margin_m: float = params.key('planner.clearance_margin_m')
    escape_check_orbits: float = params.key('planner.escape_check_orbits')
    geometry_window_s: float = params.key('planner.geometry_window_s')
    geometry_attitude_margin_rad: float = params.key('planner.geometry_attitude_margin_deg', math.radians)
    geometry_rate_margin_rad_s: float = params.key('planner.geometry_rate_margin_deg_s', math.radians)
    max_rate_rad_s: float = params.key('estimation.spin_rate_deg_s', math.radians)
    min_spin_axis_angle_from_orbit_normal_rad: float = params.key('planner.min_spin_axis_angle_from_orbit_normal_deg',
                                                                  math.radians)
    sun_direction_eci: np.ndarray | None = params.derived(_sun_direction_eci)
    max_sun_angle_from_grasp_velocity_rad: float = params.key('planner.max_sun_angle_from_grasp_velocity_deg',
                                                              math.radians)
    maneuver_lead_s: float = params.key('planner.maneuver_lead_s')
    transfer_min_s: float = params.key('planner.transfer_min_s')
    transfer_max_s: float = params.key('planner.transfer_max_s')
    delta_v_tie_mps: float = params.key('planner.delta_v_tie_mps')
    max_delta_v_per_maneuver_mps: float = params.key('chaser.thrusters.max_delta_v_per_maneuver_mps')
    impulse_error_sigma: float = params.derived(_impulse_error_sigma)
    midcourse_corrections: int = params.key('guidance.midcourse_corrections')
    accuracy: EstimateAccuracy | None = params.sub(EstimateAccuracy)
    position_tolerance_m: float = params.key('chaser.manipulator.position_tolerance_m')
    velocity_tolerance_mps: float = params.key('chaser.manipulator.velocity_tolerance_mps')
    adjust_interval_s: float = params.key('guidance.adjust_interval_s')
    command_lead_s: float = params.key('guidance.command_lead_s')
    latest_grasp_s: float = params.derived(lambda sc: sc.simulation.duration_s - sc.supervisor.capture_hold_s)
    reaim_check: bool = params.key('planner.reaim_check')

    def __post_init__(self):
        for name in ('mean_motion_rad_s', 'orbit_radius_m', 'envelope_radius_m', 'offset_m', 'flyby_duration_s',
                     'restriction_sphere_radius_m', 'escape_check_orbits', 'max_rate_rad_s', 'maneuver_lead_s',
                     'transfer_min_s', 'transfer_max_s', 'adjust_interval_s'):
            require_positive(name, getattr(self, name))
        for name in ('max_delta_v_per_maneuver_mps', 'position_tolerance_m', 'velocity_tolerance_mps'):
            require_positive(name, getattr(self, name), allow_inf=True)
        require_positive('command_lead_s', self.command_lead_s, allow_zero=True)
        require_positive('impulse_error_sigma', self.impulse_error_sigma, allow_zero=True)
        if self.midcourse_corrections < 0:
            raise ValueError(f'midcourse_corrections must be >= 0, got {self.midcourse_corrections}')
        if self.transfer_max_s < self.transfer_min_s:
            raise ValueError(f'transfer_max_s {self.transfer_max_s} s < transfer_min_s {self.transfer_min_s} s')
        lo, hi = self.offsets_range_m
        if not 0.0 < lo <= self.offset_m <= hi:
            raise ValueError(f'need 0 < offset_min_m {lo} <= offset_m {self.offset_m} <= offset_max_m {hi} [m]')
        if self.flyby_duration_max_s < self.flyby_duration_s:
            raise ValueError(f'flyby_duration_max_s {self.flyby_duration_max_s} s < flyby_duration_s '
                             f'{self.flyby_duration_s} s')

    @property
    def offsets_range_m(self):
        """(least, largest) offset delta r searched [m]."""
        return self.offset_min_m, self.offset_max_m

    @property
    def offsets_m(self):
        """The searched offsets delta r [m], the preferred offset_m first, then by distance from it."""
        lo, hi = self.offsets_range_m
        grid = {round(float(x), 9) for x in np.arange(lo, hi + 1e-9, _OFFSET_STEP_M)} | {self.offset_m, lo, hi}
        return tuple(sorted(grid, key=lambda d: (abs(d - self.offset_m), d)))

    @property
    def flyby_durations_s(self):
        """The searched fly-by durations [s], flyby_duration_s first."""
        top = self.flyby_duration_max_s
        return tuple(f * self.flyby_duration_s for f in _DURATION_FACTORS if f * self.flyby_duration_s <= top + 1e-9)

    @property
    def search_stages(self):
        """Sets of (offset, duration) searched in turn until one holds a safe plan: the preferred offset
        and fly-by duration, the other offsets at that duration, then each longer duration."""
        d0, *longer = self.flyby_durations_s
        return ([{(self.offset_m, d0)}, {(dr, d0) for dr in self.offsets_m[1:]}]
                + [{(dr, d) for dr in self.offsets_m} for d in longer])

    def transfer_max_for(self, rate_rel_rad_s):
        """Longest terminal transfer searched [s]: transfer_max_s, stretched until the grasp window holds
        _WINDOW_TURNS turns of a target turning at rate_rel_rad_s relative to hill, but below
        _TRANSFER_CAP_ORBITS orbits."""
        cap = _TRANSFER_CAP_ORBITS * 2.0 * math.pi / self.mean_motion_rad_s
        need = self.transfer_min_s + _WINDOW_TURNS * 2.0 * math.pi / rate_rel_rad_s if rate_rel_rad_s > 0 else cap
        return max(self.transfer_max_s, min(need, cap))

    def reaims(self, covariance_body):
        """Whether a plan with this target covariance checks the re-aimed passage (ReaimModel): with the estimate
        accuracy model, reaim_check on and the plan estimate's covariance given."""
        return self.accuracy is not None and self.reaim_check and covariance_body is not None

    @property
    def transfer_cap_s(self):
        """Longest terminal transfer of the extended window [s] (_TRANSFER_CAP_ORBITS orbits)."""
        return _TRANSFER_CAP_ORBITS * 2.0 * math.pi / self.mean_motion_rad_s

    def search_window(self, rate_rel_rad_s, extended=False):
        """(earliest, latest) grasp time relative to the plan time [s] for a target turning at
        rate_rel_rad_s relative to hill; extended: with the transfers up to transfer_cap_s."""
        durations = self.flyby_durations_s
        transfer = self.transfer_cap_s if extended else self.transfer_max_for(rate_rel_rad_s)
        return (self.maneuver_lead_s + self.transfer_min_s + min(durations),
                self.maneuver_lead_s + max(transfer, self.transfer_max_for(rate_rel_rad_s)) + max(durations))

    def prediction_span_s(self, omega_body_rad_s, extended=False):
        """How far past the plan time the target prediction must reach [s] for a target of inertial body
        rate omega_body_rad_s (vector or magnitude): the grasp window (extended: the extended one) and the passage
        after it. The rate relative to hill is at least |omega| - n."""
        rate = float(np.linalg.norm(omega_body_rad_s))
        return self.search_window(max(rate - self.mean_motion_rad_s, 0.0), extended)[1] + self.geometry_window_s

    @property
    def escape_duration_s(self):
        return self.escape_check_orbits * 2.0 * math.pi / self.mean_motion_rad_s


def truth_prediction(scenario, t_end):
    """MotionPrediction of the scenario's true target motion from t = 0 to t_end (zero covariance).

    The offline planner (scripts/plan_capture.py) plans from this instead of an estimate.
    """
    n = scenario.mean_motion_rad_s
    return MotionPrediction(ErrorStateDynamics(scenario.target_inertia), n, 0.0,
                            q_eci_from_body(0.0, n, scenario.q_hill_from_body0), scenario.omega_body0_rad_s,
                            None, t_end, with_covariance=False)
