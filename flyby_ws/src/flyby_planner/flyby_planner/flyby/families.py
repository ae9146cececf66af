"""Families of free (coasting) fly-by paths through one targeted state, seed 000 sections 3.2-3.3.

Pure numpy, no ROS.

The chaser coasts through the targeted grasp state (X_i, V_i) at t = 0; the CW transition matrix
(seed 000 eq 22, the flow of eq 2 with no external acceleration) gives the approach path (t < 0)
and the escape path (t > 0). Each path is measured against the target's collision region, a
``keepout.SweptRegion`` (cylinders about the spin axis, seed 000 Fig. 7-8), in two pictures:

* ``inertial``: the spin axis fixed in inertial space -- a torque-free target, the region as the
  planner sees it (``SweptRegion`` evaluated at each time; in hill the axis turns by n t about +y);
* ``hill_fixed``: the axis frozen at its t = 0 pose in hill -- the paper's "spin axis along the z
  axis of Hill's coordinates" taken literally, the picture of seed 000 Fig. 6-8.

Frames and units as in ``flyby_sim.dynamics.orbital``: hill x along-track, y orbit anti-normal, z toward
Earth; v_hill relative to the rotating frame; SI units.
"""

import dataclasses

import numpy as np

from flyby_planner.flyby.keepout import SweptRegion
from flyby_sim.dynamics.orbital import cw_transition_matrix, hill_axes_in_eci

# Seed 000 Fig. 5 and section 3.3: targeted speeds v_i [m/s].
SEED000_SPEEDS_M_S = (0.05, 0.1, 0.2, 0.35, 0.5, 1.0, 2.0)

# Seed 000 section 3.2 (Fig. 5, spin +z) and 3.3 (spin +y): spin axis, X_i [m], direction of V_i, all hill.
SEED000_CASES = {
    'in_plane': ((0.0, 0.0, 1.0), (0.0, -1.5, -1.5), (1.0, 0.0, 0.0)),
    'out_of_plane': ((0.0, 1.0, 0.0), (-1.5, -1.5, 0.0), (0.0, 0.0, 1.0)),
}
# The collision cylinder of both cases: X_i lies on its rim, as in the paper.
SEED000_CYLINDER_RADIUS_M = 1.5
SEED000_CYLINDER_HALF_LENGTH_M = 1.5


@dataclasses.dataclass(frozen=True)
class RegionView:
    """Paths (K, M) in the region's cylinder coordinates [m].

    distance_m: signed distance to the region (negative inside); axial_m, radial_m: coordinates
    about the axis; axial_gap_m: distance outside the region's axial slab (negative inside it).
    """

    distance_m: np.ndarray
    axial_m: np.ndarray
    radial_m: np.ndarray
    axial_gap_m: np.ndarray


@dataclasses.dataclass(frozen=True)
class CoastFamily:
    """K coasting paths on the time grid t_s (M,) [s]; t_s < 0 approach, t_s > 0 escape.

    r_hill, v_hill: (K, M, 3) [m], [m/s]; inertial, hill_fixed: RegionView of the two pictures.
    """

    t_s: np.ndarray
    r_hill: np.ndarray
    v_hill: np.ndarray
    inertial: RegionView
    hill_fixed: RegionView


def time_grid(t_max_s=300.0, dt_s=1.0, t_fine_s=10.0, dt_fine_s=0.05):
    """Symmetric grid on [-t_max_s, t_max_s] [s] with step dt_fine_s for |t| <= t_fine_s, containing 0."""
    coarse = np.arange(-t_max_s, t_max_s + 0.5 * dt_s, dt_s)
    fine = np.arange(-t_fine_s, t_fine_s + 0.5 * dt_fine_s, dt_fine_s)
    return np.unique(np.round(np.concatenate((coarse, fine, [0.0])), 9))


def cylinder_region(axis_hill0, radius_m, half_length_m, n):
    """SweptRegion of one cylinder centred on the CoM whose axis is the hill direction axis_hill0 at t = 0."""
    axis_eci = hill_axes_in_eci(0.0, n) @ np.asarray(axis_hill0, dtype=float)
    return SweptRegion(axis_eci=axis_eci, names=('cylinder',), axial_min_m=np.array([-half_length_m]),
                       axial_max_m=np.array([half_length_m]), radius_m=np.array([radius_m]))


def coast_paths(r_target_hill, v_target_hill, n, t_s):
    """CW paths (K, M, 3) of position and velocity through (r_target_hill, v_target_hill[k]) at t = 0.

    Seed 000 eq 22 (Phi(t) for negative t is the backward flow, eq 23). v_target_hill: (K, 3).
    """
    phi = np.array([cw_transition_matrix(n, t) for t in t_s])  # (M, 6, 6)
    v0 = np.atleast_2d(np.asarray(v_target_hill, dtype=float))
    x0 = np.concatenate((np.broadcast_to(np.asarray(r_target_hill, dtype=float), v0.shape), v0), axis=1)
    x = np.einsum('mij,kj->kmi', phi, x0)
    return x[..., :3], x[..., 3:]


def region_view(region, r_hill, t_s, n, axis_fixed_in_hill=False):
    """RegionView of paths r_hill (K, M, 3) on t_s (M,) against region (SweptRegion methods).

    axis_fixed_in_hill evaluates the region at its t = 0 pose for every time (the paper's picture).
    """
    k, m, _ = r_hill.shape
    t_eval = np.zeros(m) if axis_fixed_in_hill else np.asarray(t_s, dtype=float)
    points = r_hill.reshape(k * m, 3)
    times = np.tile(t_eval, k)
    axial, radial = region.axial_radial(points, times, n)
    distance = region.signed_distance(points, times, n)
    gap = np.maximum(axial - np.max(region.axial_max_m), np.min(region.axial_min_m) - axial)
    return RegionView(*(a.reshape(k, m) for a in (distance, axial, radial, gap)))


def coast_family(r_target_hill, v_target_hill, region, n, t_s):
    """CoastFamily of the paths through (r_target_hill, each v_target_hill (K, 3)) against region."""
    r_hill, v_hill = coast_paths(r_target_hill, v_target_hill, n, t_s)
    return CoastFamily(t_s=np.asarray(t_s, dtype=float), r_hill=r_hill, v_hill=v_hill,
                       inertial=region_view(region, r_hill, t_s, n),
                       hill_fixed=region_view(region, r_hill, t_s, n, axis_fixed_in_hill=True))


def seed000_family(case, n, t_s, speeds_m_s=SEED000_SPEEDS_M_S):
    """(CoastFamily, region) of seed 000 Fig. 5-7 (case 'in_plane') or Fig. 8 ('out_of_plane')."""
    axis_hill0, r_target_hill, v_direction_hill = SEED000_CASES[case]
    region = cylinder_region(axis_hill0, SEED000_CYLINDER_RADIUS_M, SEED000_CYLINDER_HALF_LENGTH_M, n)
    v_target_hill = np.outer(speeds_m_s, v_direction_hill)
    return coast_family(r_target_hill, v_target_hill, region, n, t_s), region
