"""What the planner publishes (PlannerCore's outputs, in order, for the planner node and the headless driver): a
selected fly-by (``PlanPublished``), an optimal or synchronized approach (``TrajectoryPublished``), a refusal's
markers (``PlanRefused``), a re-aimed grasp (``AimUpdate``), and what a plan looks like in a 3-D viewer
(``PlanMarkers``). Frames and units as in flyby_planner.flyby.grasp_search (hill, SI).
"""

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class GraspState:
    """The grasp point at the grasp time t [s]: x_g [m] and v_g [m/s] (relative to hill) in hill, and the
    target's attitude q_hill_from_body and inertial body rate omega_body [rad/s] there."""

    t: float
    x_g: np.ndarray
    v_g: np.ndarray
    q_hill_from_body: np.ndarray
    omega_body: np.ndarray


@dataclasses.dataclass(frozen=True)
class PlanMarkers:
    """What a plan looks like in a 3-D viewer, in hill: restriction-sphere radius, the swept keep-out
    cylinders (centre, unit axis, radius, height), the grasp point, the fly-by
    target and initial points and the path (None where the plan has none)."""

    sphere_radius_m: float
    cylinders: tuple
    grasp_point: np.ndarray = None
    flyby_points: tuple = ()
    path_r_hill: np.ndarray = None


@dataclasses.dataclass(frozen=True)
class PlanPublished:
    """A selected plan: planner/grasp, planner/flyby_target (X_Ft, V_Ft at t_f, eq 20-21),
    planner/flyby_initial (X_Fi, V_Fi at t_i, eq 23), planner/path (stamped t_plan) and its markers."""

    t_plan: float
    grasp: GraspState
    t_f: float
    x_ft: np.ndarray
    v_ft: np.ndarray
    t_i: float
    x_fi: np.ndarray
    v_fi: np.ndarray
    path_t: np.ndarray
    path_r_hill: np.ndarray
    markers: PlanMarkers


@dataclasses.dataclass(frozen=True)
class TrajectoryPublished:
    """An optimal approach: planner/grasp, planner/flyby_target (X_Ft, V_Ft at the grasp time t_f, eq 20-21),
    planner/trajectory (stamp t_start; trajectory = cost.Trajectory: t_s, r_hill, v_hill, a_hill), planner/path
    (stamped t_plan) and its markers."""

    t_plan: float
    grasp: GraspState
    t_f: float
    x_ft: np.ndarray
    v_ft: np.ndarray
    t_start: float
    trajectory: object
    markers: PlanMarkers


@dataclasses.dataclass(frozen=True)
class PlanRefused:
    """A refused plan: only its markers (the keep-out region that defeated it) are published."""

    t_plan: float
    markers: PlanMarkers


@dataclasses.dataclass(frozen=True)
class AimUpdate:
    """The grasp and fly-by target point guidance re-aimed at (planner/grasp, planner/flyby_target)."""

    grasp: GraspState
    x_ft: np.ndarray
    v_ft: np.ndarray


def plan_markers(plan, config):
    """PlanMarkers of a plan: the keep-out cylinders about the spin axis at the grasp (or plan) time."""
    n = config.mean_motion_rad_s
    chosen = plan.selected
    cylinders = []
    if plan.region is not None:
        region = plan.region
        axis = region.axis_hill(chosen.t_grasp if chosen else plan.t_plan, n)
        cylinders = [(0.5 * (lo + hi) * axis, axis, radius, hi - lo)
                     for lo, hi, radius in zip(region.axial_min_m, region.axial_max_m, region.radius_m, strict=True)]
    if chosen is None:
        return PlanMarkers(config.restriction_sphere_radius_m, tuple(cylinders))
    return PlanMarkers(config.restriction_sphere_radius_m, tuple(cylinders), chosen.x_g, (chosen.x_ft, chosen.x_fi),
                       plan.path_r_hill)
