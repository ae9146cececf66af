"""The errors of a mass-property estimate (``mass_properties_model.MassPropertyEstimate``) against the truth, in the
filter's coordinates (``mass_properties_model``), and its consistency: which principal axes and parameters the true
moments define, the axes' angles, the ten parameters' error and NEES (docs/post_capture.md). No ROS.
"""

import numpy as np

from flyby_estimation.mass_properties_model import PARAMETER_SLICE, j_from_moments
from flyby_sim.dynamics.rotation import quat_conjugate, quat_multiply, quat_to_matrix_many, rotation_vector_from_quat


def defined_axes(principal_moments_kg_m2, rel_tol=1e-9):
    """(3,) bool: the principal axes a body's moments define, those whose moment differs from both others (by more
    than rel_tol of the largest); about two equal moments (a body symmetric about the third axis, seed 004's cylinder)
    any pair of perpendicular axes in their plane is principal."""
    m = np.asarray(principal_moments_kg_m2, dtype=float)
    gaps = np.where(np.eye(3, dtype=bool), np.inf, np.abs(m[:, None] - m[None, :]))
    return gaps.min(axis=1) > rel_tol * float(np.max(np.abs(m)))


def principal_axis_errors_rad(q_body_from_principal_est, q_body_from_principal_true):
    """Angle [rad] between each estimated and true principal axis (3,), the axes' signs ignored (an axis is a
    line). Where two true moments are equal only the third axis is defined: the caller picks which to read."""
    c_est = quat_to_matrix_many(np.asarray(q_body_from_principal_est, dtype=float)[None, :])[0]
    c_true = quat_to_matrix_many(np.asarray(q_body_from_principal_true, dtype=float)[None, :])[0]
    cosines = np.clip(np.abs(np.einsum('ak,ak->k', c_est, c_true)), 0.0, 1.0)
    return np.arccos(cosines)


def parameter_error(estimate, mass_kg, com_body_m, q_body_from_principal, principal_moments_kg_m2):
    """The error (10,) of the ten parameters (M, dphi, X_s, j) of a MassPropertyEstimate, truth minus estimate in
    the filter's coordinates (module doc): dphi = log(Q_est^-1 Q_true) about the estimate's principal axes, j of the
    true moments less the estimate's; the true moments (in the order of the filter's principal axes) and axes
    q_body_from_principal, mass [kg] and CoM X_s [m, chaser_body]."""
    dphi = rotation_vector_from_quat(quat_multiply(quat_conjugate(estimate.q_body_from_principal),
                                                   q_body_from_principal))
    return np.concatenate(([mass_kg - estimate.target_mass_kg], dphi,
                           np.asarray(com_body_m, dtype=float) - estimate.target_com_body_m,
                           j_from_moments(principal_moments_kg_m2) - j_from_moments(estimate.principal_moments_kg_m2)))


def defined_parameters(principal_moments_kg_m2, rel_tol=1e-9):
    """Indices into the ten parameters (M, dphi, X_s, j) that the true moments define: all but a rotation dphi_k
    about a principal axis k whose two other moments are equal (within rel_tol of the largest): it only turns two
    equal axes into each other (seed 004 §3.1's cylinder: the rotation about its symmetry axis)."""
    m = np.asarray(principal_moments_kg_m2, dtype=float)
    scale = rel_tol * float(np.max(np.abs(m)))
    return [0] + [1 + k for k in range(3) if abs(m[(k + 1) % 3] - m[(k + 2) % 3]) > scale] + list(range(4, 10))


def parameter_nees(estimate, error, principal_moments_kg_m2):
    """(NEES of the error (10,) over the defined parameters with the estimate's own covariance, each parameter's
    z = error / sigma (10,)): the filter's consistency (docs/post_capture.md)."""
    p = estimate.covariance[PARAMETER_SLICE, PARAMETER_SLICE]
    keep = defined_parameters(principal_moments_kg_m2)
    e = np.asarray(error, dtype=float)
    return float(e[keep] @ np.linalg.solve(p[np.ix_(keep, keep)], e[keep])), e / np.sqrt(np.diag(p))
