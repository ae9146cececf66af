"""Hypothesis strategies of real rigid bodies, shared by the property tests of the chaser's rigid body
(flyby_sim's test_rigid_body.py and test_chaser_body.py; on the test path through pytest.ini)."""

import numpy as np
from hypothesis import strategies as st

from flyby_sim.dynamics.rotation import quat_from_rotation_vector, quat_to_matrix

principal_moments = st.lists(st.floats(5.0, 50.0), min_size=3, max_size=3).filter(
    lambda m: 2.0 * max(m) < sum(m))  # the triangle inequality of a real body
rate = st.floats(-0.3, 0.3)
rotation_vector = st.tuples(st.floats(-3.0, 3.0), st.floats(-3.0, 3.0), st.floats(-3.0, 3.0))


def inertia_from(moments, rotvec):
    """A full inertia matrix: principal moments about axes turned by rotvec from the body axes."""
    c = quat_to_matrix(quat_from_rotation_vector(rotvec))
    inertia = c @ np.diag(moments) @ c.T
    return 0.5 * (inertia + inertia.T)  # symmetric to the bit, as validated_inertia requires
