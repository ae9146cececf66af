"""The target's swept keep-out region and the chaser's clearance from it (seed 000 section 3.2, Fig. 7-8).

Pure numpy, no ROS.

A torque-free target rotates about its angular momentum H, which is fixed in inertial space. Every
body point then stays on a circle about the H axis through the centre of mass (for a pure spin) or
moves within a band of axial height and radius (a tumbler's nutation). The region the body can
occupy at *any* rotation angle -- the "collision region" cylinder of seed 000 Fig. 7-8 -- is
therefore a solid of revolution about H. Each body-frame box contributes a cylinder
{axial in [a_min, a_max], radius <= r_max} about H: a_min, a_max are the extremes of the box corners'
projections on the H direction in body axes (a linear function is extreme at a vertex) and r_max
the largest corner distance from the axis (a convex function is largest at a vertex). Filling the
cylinder down to radius 0 is conservative (the inner hole of a panel's annulus lies inside the bus
for the targets we fly, and a plan that clears the full cylinder clears the annulus).

For a tumbler the H direction in body axes, I omega_body / |I omega_body|, moves along the polhode;
the region is the union over the sampled motion (the caller samples at least one polhode period).

The region is fixed in inertial space, so in ``hill`` its axis turns by n t about +y
(flyby_sim.dynamics.orbital.eci_vector_in_hill); clearances are evaluated at each time with the axis of that
time. The chaser is a sphere of ``envelope_radius_m`` (DESIGN §5).
"""

import dataclasses

import numpy as np

from flyby_sim.dynamics.geometry import signed_distance_to_box
from flyby_sim.dynamics.orbital import eci_vector_in_hill
from flyby_sim.dynamics.rotation import quat_to_matrix

_CORNER_SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)


@dataclasses.dataclass(frozen=True)
class SweptRegion:
    """Union of cylinders about the target's angular-momentum axis (module doc).

    Attributes:
        axis_eci: unit angular-momentum direction in ECI (inertially fixed).
        names: one name per body box.
        axial_min_m, axial_max_m, radius_m: (K,) cylinder bounds per box [m], axial along axis_eci
            from the centre of mass.
    """

    axis_eci: np.ndarray
    names: tuple
    axial_min_m: np.ndarray
    axial_max_m: np.ndarray
    radius_m: np.ndarray

    @property
    def bounding_radius_m(self):
        """Radius of the sphere about the centre of mass that contains the whole region [m]."""
        a = np.maximum(np.abs(self.axial_min_m), np.abs(self.axial_max_m))
        return float(np.max(np.hypot(a, self.radius_m)))

    def axis_hill(self, t, n):
        """The region's axis in hill at time(s) t [s]: (3,) or (N, 3)."""
        return eci_vector_in_hill(self.axis_eci, t, n)

    def axial_radial(self, r_hill, t, n):
        """(axial, radial) coordinates [m] of hill points (N, 3) at times t (N,) about the axis."""
        r = np.atleast_2d(np.asarray(r_hill, dtype=float))
        axis = np.atleast_2d(self.axis_hill(t, n))
        axial = np.sum(r * axis, axis=1)
        radial = np.sqrt(np.maximum(np.sum(r * r, axis=1) - axial * axial, 0.0))
        return axial, radial

    def signed_distance(self, r_hill, t, n):
        """Signed distance (N,) from hill points at times t to the region; negative inside [m]."""
        axial, radial = self.axial_radial(r_hill, t, n)
        p = np.stack((axial, radial), axis=1)
        # In the (axial, radial) half-plane a cylinder is the box [a_min, a_max] x [-r_max, r_max].
        per_box = [signed_distance_to_box(p, (0.5 * (lo + hi), 0.0), (hi - lo, 2.0 * rad))
                   for lo, hi, rad in zip(self.axial_min_m, self.axial_max_m, self.radius_m, strict=True)]
        return np.min(per_box, axis=0)

    def clearance(self, r_hill, t, n, envelope_radius_m):
        """Gap (N,) between the chaser envelope sphere and the region [m]; < 0 is a possible collision."""
        return self.signed_distance(r_hill, t, n) - envelope_radius_m


def has_spin_axis(inertia, omega_body):
    """True if the rate omega_body [rad/s] gives the target an angular momentum I omega (finite, nonzero): the axis
    swept_region needs. A filter restarted from one measurement (flyby_estimation.target_filter, its reset) has
    omega_body zero: no axis."""
    h = np.asarray(inertia, dtype=float) @ np.asarray(omega_body, dtype=float)
    norm = float(np.linalg.norm(h))
    return bool(np.isfinite(norm) and norm > 0.0)


def any_attitude_region(boxes):
    """The SweptRegion that holds the body at every attitude, for a target whose spin axis is unknown: each box's
    cylinder of radius and half-height its farthest corner's distance from the centre of mass (it holds that
    sphere), about an arbitrary axis (ECI z). Conservative beyond any swept_region of the same boxes."""
    names, reach = [], []
    for name, center, size in zip(boxes.names, boxes.center_body_m, boxes.size_m, strict=True):
        corners = np.asarray(center, dtype=float) + 0.5 * _CORNER_SIGNS * np.asarray(size, dtype=float)
        names.append(name)
        reach.append(float(np.linalg.norm(corners, axis=1).max()))
    reach = np.array(reach)
    return SweptRegion(axis_eci=np.array((0.0, 0.0, 1.0)), names=tuple(names), axial_min_m=-reach,
                       axial_max_m=reach.copy(), radius_m=reach.copy())


def swept_region(boxes, inertia, q_eci_from_body, omega_body):
    """SweptRegion of body boxes rotating torque-free, from attitude samples of the motion.

    Args:
        boxes: target body-frame boxes with ``names``, ``center_body_m`` (K, 3) and ``size_m`` (K, 3)
            (flyby_sim.scenario.Boxes, ``Scenario.boxes``).
        inertia: 3x3 body inertia [kg m^2] (angular momentum H = I omega_body).
        q_eci_from_body: (M, 4) attitude samples (x, y, z, w) over the motion (one is enough for a
            principal-axis spin).
        omega_body: (M, 3) inertial angular velocity samples in body axes [rad/s], nonzero.

    Returns:
        SweptRegion. The H direction in ECI is taken from the first sample; ValueError if the samples
        disagree on it by more than 1 deg (they are not one torque-free motion).
    """
    q = np.atleast_2d(np.asarray(q_eci_from_body, dtype=float))
    w = np.atleast_2d(np.asarray(omega_body, dtype=float))
    if q.shape[0] != w.shape[0] or q.shape[1] != 4 or w.shape[1] != 3:
        raise ValueError(f'need matching (M, 4) attitude and (M, 3) rate samples, got {q.shape} and {w.shape}')
    h_body = w @ np.asarray(inertia, dtype=float).T
    h_norm = np.linalg.norm(h_body, axis=1)
    if not np.all(np.isfinite(h_norm) & (h_norm > 0.0)):
        raise ValueError('the target has no angular momentum (omega_body zero or not finite): no spin axis')
    axis_body = h_body / h_norm[:, None]
    axis_eci_samples = np.array([quat_to_matrix(qi) @ ai for qi, ai in zip(q, axis_body, strict=True)])
    axis_eci = axis_eci_samples[0]
    spread = np.degrees(np.arccos(np.clip(axis_eci_samples @ axis_eci, -1.0, 1.0))).max()
    if spread > 1.0:
        raise ValueError(f'angular momentum direction varies by {spread:.3g} deg over the samples; '
                         'they are not one torque-free motion')
    names, lo, hi, rad = [], [], [], []
    for name, center, size in zip(boxes.names, boxes.center_body_m, boxes.size_m, strict=True):
        corners = np.asarray(center, dtype=float) + 0.5 * _CORNER_SIGNS * np.asarray(size, dtype=float)
        axial = axis_body @ corners.T  # (M, 8)
        radial2 = np.sum(corners * corners, axis=1)[None, :] - axial * axial
        names.append(name)
        lo.append(axial.min())
        hi.append(axial.max())
        rad.append(float(np.sqrt(np.maximum(radial2, 0.0).max())))
    return SweptRegion(axis_eci=axis_eci, names=tuple(names), axial_min_m=np.array(lo),
                       axial_max_m=np.array(hi), radius_m=np.array(rad))
