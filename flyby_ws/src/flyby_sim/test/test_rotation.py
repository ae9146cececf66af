"""rotation.py against scipy.spatial.transform.Rotation (same (x, y, z, w) order), plus properties."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_axis_angle,
    quat_from_matrix,
    quat_from_rotation_vector,
    quat_multiply,
    quat_normalize,
    quat_rotate,
    quat_rotate_many,
    quat_to_matrix,
    quat_to_matrix_many,
    random_small_rotation,
    rotation_angle_many,
    rotation_vector_from_quat,
)

RNG = np.random.default_rng(20240601)
QUATS = Rotation.random(200, random_state=RNG).as_quat()
VECTORS = RNG.normal(size=(200, 3))


def same_rotation(q1, q2, tol=1e-12):
    return min(np.max(np.abs(q1 - q2)), np.max(np.abs(q1 + q2))) < tol


def test_multiply_and_conjugate_match_scipy():
    for qa, qb in zip(QUATS[:-1], QUATS[1:], strict=True):
        expected = (Rotation.from_quat(qa) * Rotation.from_quat(qb)).as_quat()
        assert same_rotation(quat_multiply(qa, qb), expected)
        assert same_rotation(quat_conjugate(qa), Rotation.from_quat(qa).inv().as_quat())


def test_matrix_conversions_match_scipy():
    for q in QUATS:
        np.testing.assert_allclose(quat_to_matrix(q), Rotation.from_quat(q).as_matrix(), atol=1e-14)
        assert same_rotation(quat_from_matrix(Rotation.from_quat(q).as_matrix()), q)
    # Each branch of Shepperd's method: rotations by pi about x, y, z, and the identity.
    for q in ([1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]):
        assert same_rotation(quat_from_matrix(quat_to_matrix(q)), np.array(q, dtype=float))


def test_rotate_matches_scipy():
    for q, v in zip(QUATS, VECTORS, strict=True):
        np.testing.assert_allclose(quat_rotate(q, v), Rotation.from_quat(q).apply(v), atol=1e-14)


def test_vectorized_forms_match_scipy():
    """quat_to_matrix_many (quaternions not unit, as a filter's are before renormalizing) and quat_rotate_many."""
    scaled = QUATS * RNG.uniform(0.5, 2.0, size=(len(QUATS), 1))
    np.testing.assert_allclose(quat_to_matrix_many(scaled), Rotation.from_quat(QUATS).as_matrix(), atol=1e-14)
    assert quat_to_matrix_many(QUATS[0]).shape == (1, 3, 3)
    np.testing.assert_allclose(quat_rotate_many(QUATS, VECTORS), Rotation.from_quat(QUATS).apply(VECTORS), atol=1e-14)
    np.testing.assert_allclose(quat_rotate_many(QUATS[0], VECTORS), Rotation.from_quat(QUATS[0]).apply(VECTORS),
                               atol=1e-14)


def test_rotation_angle_many_is_the_norm_of_the_rotation_vector():
    """Quaternions not unit, either sign, and angles down to 1e-9 rad (the small-angle branch of the log map)."""
    small = np.array([quat_from_rotation_vector(v) for v in RNG.normal(size=(20, 3)) * 1e-9])
    quats = np.vstack((QUATS, -QUATS[:50], small)) * RNG.uniform(0.5, 2.0, size=(270, 1))
    expected = [np.linalg.norm(rotation_vector_from_quat(q)) for q in quats]
    np.testing.assert_allclose(rotation_angle_many(quats), expected, rtol=1e-13, atol=0.0)
    assert rotation_angle_many(QUATS[0]).shape == (1,)


def test_rotation_vector_maps_match_scipy():
    for q in QUATS:
        rotvec = Rotation.from_quat(q).as_rotvec()
        assert same_rotation(quat_from_rotation_vector(rotvec), q)
        np.testing.assert_allclose(rotation_vector_from_quat(q), rotvec, atol=1e-12)
    tiny = np.array([1e-9, -2e-9, 3e-10])
    assert same_rotation(quat_from_rotation_vector(tiny), Rotation.from_rotvec(tiny).as_quat(), 1e-18)
    np.testing.assert_allclose(rotation_vector_from_quat(quat_from_rotation_vector(tiny)), tiny, rtol=1e-12)


def test_axis_angle_matches_scipy():
    q = quat_from_axis_angle([0.0, 2.0, 0.0], 0.3)
    assert same_rotation(q, Rotation.from_rotvec([0.0, 0.3, 0.0]).as_quat())


@pytest.mark.parametrize('bad', [[0.0, 0.0, 0.0, 0.0], [math.nan, 0.0, 0.0, 1.0]])
def test_normalize_rejects_degenerate_quaternion(bad):
    with pytest.raises(ValueError, match='cannot be normalized'):
        quat_normalize(bad)


def test_axis_angle_rejects_zero_axis():
    with pytest.raises(ValueError, match='rotation axis'):
        quat_from_axis_angle([0.0, 0.0, 0.0], 1.0)


def test_random_small_rotation_has_the_given_sigma_per_axis():
    rng = np.random.default_rng(5)
    sigma = 0.02
    rotvecs = np.array([rotation_vector_from_quat(random_small_rotation(rng, sigma)) for _ in range(20000)])
    np.testing.assert_allclose(rotvecs.std(axis=0), sigma, rtol=0.03)
    np.testing.assert_allclose(rotvecs.mean(axis=0), 0.0, atol=4 * sigma / math.sqrt(20000))


unit_floats = st.floats(-1.0, 1.0, allow_nan=False)
quaternions = st.tuples(unit_floats, unit_floats, unit_floats, unit_floats).filter(
    lambda q: sum(c * c for c in q) > 1e-6).map(quat_normalize)
rotation_vectors = st.tuples(*(st.floats(-10.0, 10.0, allow_nan=False),) * 3)


@settings(max_examples=200, deadline=None)
@given(quaternions, quaternions, rotation_vectors)
def test_property_products_and_exp_map_stay_unit(q1, q2, rotvec):
    assert abs(np.linalg.norm(quat_multiply(q1, q2)) - 1.0) < 1e-14
    assert abs(np.linalg.norm(quat_from_rotation_vector(rotvec)) - 1.0) < 1e-14
    # Rotation preserves length; composing with the conjugate is the identity.
    v = np.array(rotvec)
    assert abs(np.linalg.norm(quat_rotate(q1, v)) - np.linalg.norm(v)) < 1e-12 * (1.0 + np.linalg.norm(v))
    assert same_rotation(quat_multiply(q1, quat_conjugate(q1)), np.array([0.0, 0.0, 0.0, 1.0]), 1e-14)
