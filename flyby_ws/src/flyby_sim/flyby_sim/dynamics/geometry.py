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


def outward_normal(point_body, boxes, tolerance_m=1e-6):
    """The unit outward normal (3,) of the boxes' outer surface at a body point on it: the normal of the face the
    point lies on (within tolerance_m), the normalized sum of the faces' normals on an edge or a corner; None when
    the point is not on the outer surface (off it, or on a face buried in another box).

    ``boxes`` is a sequence of (center_m, size_m) pairs in the target body frame.
    """
    p = np.asarray(point_body, dtype=float)
    depth = [float(signed_distance_to_box(p, c, s)[0]) for c, s in boxes]
    if min(depth) < -tolerance_m or min(depth) > tolerance_m:
        return None
    normal = np.zeros(3)
    for (center, size), d in zip(boxes, depth, strict=True):
        if abs(d) > tolerance_m:
            continue
        offset = p - np.asarray(center, dtype=float)
        half = 0.5 * np.asarray(size, dtype=float)
        on_face = np.abs(np.abs(offset) - half) <= tolerance_m
        normal += np.where(on_face, np.sign(offset), 0.0)
    norm = float(np.linalg.norm(normal))
    return normal / norm if norm > 0.0 else None
