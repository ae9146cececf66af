"""Distances between the chaser's spherical envelope and the target's body-frame boxes.

Quaternions are (x, y, z, w), scalar last; ``q_hill_from_body`` rotates body vectors into hill.
"""

import numpy as np

from flyby_sim.dynamics.rotation import quat_rotate_many


def rotate_into_body(q_hill_from_body, r_hill):
    """Hill vectors (N,3) expressed in body axes, for per-sample attitudes (N,4) or one (4,)."""
    q = np.atleast_2d(np.asarray(q_hill_from_body, dtype=float))
    return quat_rotate_many(np.column_stack((-q[:, :3], q[:, 3:4])), r_hill)  # the conjugate: hill -> body


def signed_distance_to_box(p_body, center_m, size_m):
    """Signed distance (N,) from body points to an axis-aligned box; negative inside."""
    d = np.abs(np.atleast_2d(p_body) - np.asarray(center_m)) - 0.5 * np.asarray(size_m)
    outside = np.linalg.norm(np.maximum(d, 0.0), axis=1)
    inside = np.minimum(d.max(axis=1), 0.0)
    return outside + inside


def clearance(r_hill, q_hill_from_body, boxes, envelope_radius_m):
    """Gap (N,) between the chaser envelope sphere and the nearest target box; < 0 is contact.

    ``boxes`` is a sequence of (center_m, size_m) pairs in the target body frame.
    """
    p_body = rotate_into_body(q_hill_from_body, r_hill)
    distances = [signed_distance_to_box(p_body, center, size) for center, size in boxes]
    return np.min(distances, axis=0) - envelope_radius_m
