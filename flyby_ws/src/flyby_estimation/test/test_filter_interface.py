"""filter_interface.kalman_update_first_three against filterpy's KalmanFilter.update with H = [I 0]."""

import warnings

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter

from flyby_estimation.filter_interface import kalman_update_first_three


def test_update_of_the_first_three_states_is_filterpys():
    """The same state and Joseph-form covariance as filterpy (what both filters used before), and the NIS."""
    rng = np.random.default_rng(7)
    for _ in range(50):
        a = rng.normal(size=(6, 6))
        p = a @ a.T + 1e-3 * np.eye(6)
        b = rng.normal(size=(3, 3))
        r = b @ b.T + 1e-2 * np.eye(3)
        x = rng.normal(size=(6, 1))
        z = rng.normal(size=3)
        kf = KalmanFilter(dim_x=6, dim_z=3)
        kf.x, kf.P, kf.R, kf.H = x.copy(), p.copy(), r, np.hstack((np.eye(3), np.zeros((3, 3))))
        kf.update(z)
        y = z - x[:3, 0]
        nis, x_new, p_new = kalman_update_first_three(x, p, y, r)
        np.testing.assert_array_equal(x_new, kf.x)  # to the bit: the same products in the same order
        np.testing.assert_array_equal(p_new, kf.P)
        assert np.isclose(nis, y @ np.linalg.solve(p[:3, :3] + r, y), rtol=1e-12)


def test_update_of_the_first_three_states_is_the_previous_arithmetic_and_refuses_a_singular_s():
    """The same NIS, state and covariance as the previous arithmetic (np.linalg.inv, np.eye, @), to the bit, for
    the 6-state filters and a 9-state one; a singular S = P[:3, :3] + R raises LinAlgError, as np.linalg.inv did."""
    rng = np.random.default_rng(8)
    for n in (6, 9):
        for _ in range(30):
            a = rng.normal(size=(n, n))
            p = a @ a.T + 1e-3 * np.eye(n)
            r = np.diag(rng.uniform(1e-4, 1e-2, 3))
            x, y = rng.normal(size=(n, 1)), rng.normal(size=3)
            s_inv = np.linalg.inv(p[:3, :3] + r)
            k = p[:, :3] @ s_inv
            i_kh = np.eye(n)
            i_kh[:, :3] -= k
            nis, x_new, p_new = kalman_update_first_three(x, p, y, r)
            assert nis == float(y @ s_inv @ y)
            np.testing.assert_array_equal(x_new, x + k @ y[:, None])
            np.testing.assert_array_equal(p_new, i_kh @ p @ i_kh.T + k @ r @ k.T)
    p = np.zeros((6, 6))
    with pytest.raises(np.linalg.LinAlgError), warnings.catch_warnings():
        warnings.simplefilter('ignore', RuntimeWarning)  # the inverse's own warning before the refusal
        kalman_update_first_three(np.zeros((6, 1)), p, np.ones(3), np.zeros((3, 3)))
