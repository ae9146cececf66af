"""The combined body's translation and its CoM in TRANSPORT, one Kalman filter (DESIGN §10, docs/transport.md; no ROS).

State: the combined CoM's deviation (r, v) from a reference coasted by the plant's relative dynamics (seed 000 eq 1,
or eq 2 under CW; the deviation by CW's transition matrix, seed 000 eq 22, folded into the reference after each
update), and p, the chaser's CoM from the combined one [m, chaser_body], a constant. The sensor measures the chaser's
CoM: y = r + C p + noise, C the attitude estimate (hill from chaser_body).

Why one filter sees p: a body held at rest inertially turns in hill at the orbit's rate, so C p traces a circle, and
no CW motion does (CW's in-plane ellipse is twice as long along-track as it is radially, its out-of-plane motion has
no constant); a body slewing turns C p faster still. A filter that took p as known would carry its error as a
velocity n x C dp, 1 um/s a millimetre: on 2000 kg a fifth of seed 004 §3.2's 0.01 N s. Across a firing (a known
input, ``add_thrust``, with its execution error) the filter keeps what it knows of r, v and p, so the circle is seen
over the whole transport rather than over one coast.

Gate and restart as the other filters (``filter_interface``): a restart takes the position from the measurement
and keeps p and what is known of it. The caller may hold p as a consider parameter (Schmidt) through an update whose
model it does not trust for p (``update``'s estimate_p).
"""

import math

import numpy as np

from flyby_estimation.filter_interface import FilterBase
from flyby_estimation.relative_nav import MAX_TRANSITIONS, white_accel_q
from flyby_msgs_py.stamped import put_bounded
from flyby_sim.dynamics.orbital import cw_transition_matrix, relative_accel_components, rk4_step_floats

_I3 = np.eye(3)


class CombinedComFilter(FilterBase):
    """The filter of the module doc, on a ``relative_nav.RelativeNavConfig`` (its position sigma, white acceleration,
    velocity prior, gate, restart run, dynamics and RK4 step)."""

    def __init__(self, config, p_prior_m, p_covariance_m2):
        """p_prior_m and its 3x3 covariance: the chaser's CoM from the combined one [m, chaser_body], the
        mass-property estimate's."""
        super().__init__(config.gate_probability, config.max_consecutive_outliers, config.position_sigma_m, ('hill',))
        self.config = config
        self.n = config.mean_motion_rad_s
        self._accel = relative_accel_components(config.dynamics, self.n, config.radius_m)
        self._r = config.position_sigma_m**2 * _I3
        self._x_ref = None  # the reference (r, v) of the combined CoM, hill, floats
        self.p = np.asarray(p_prior_m, dtype=float).copy()
        self.covariance = np.zeros((9, 9))
        self.covariance[6:, 6:] = np.asarray(p_covariance_m2, dtype=float)
        self._transitions = {}  # dt [s] -> (Phi, Q), 9x9, the last MAX_TRANSITIONS

    def initialize(self, t, y_chaser_hill, c_hill_from_body):
        """The first measurement: the combined CoM at y - C p, its velocity at the prior's sigma, p and its covariance
        kept."""
        c = np.asarray(c_hill_from_body, dtype=float)
        self._t = float(t)
        self._x_ref = [*(np.asarray(y_chaser_hill, dtype=float) - c @ self.p).tolist(), 0.0, 0.0, 0.0]
        p_pp = self.covariance[6:, 6:].copy()
        self.covariance = np.zeros((9, 9))
        self.covariance[:3, :3] = self._r + c @ p_pp @ c.T
        self.covariance[:3, 6:] = -c @ p_pp
        self.covariance[6:, :3] = self.covariance[:3, 6:].T
        self.covariance[3:6, 3:6] = self.config.initial_velocity_sigma_mps**2 * _I3
        self.covariance[6:, 6:] = p_pp
        self._rejected.clear()

    def state(self):
        """(r_hill, v_hill, their 6x6 covariance) of the combined CoM at the filter time."""
        x = np.asarray(self._x_ref)
        return x[:3], x[3:], self.covariance[:6, :6].copy()

    @property
    def p_covariance_m2(self):
        return self.covariance[6:, 6:].copy()

    def propagate_to(self, t):
        """The reference by RK4 on the relative dynamics, the covariance by CW's transition and the white
        acceleration (p constant), to t >= the filter time [s]."""
        while self._t < t - 1e-9:
            dt = min(self.config.max_rk4_step_s, t - self._t)
            self._x_ref = rk4_step_floats(self._rhs, self._t, self._x_ref, dt)
            phi, q = self._transition(dt)
            self.covariance = phi @ self.covariance @ phi.T + q
            self._t += dt
        self._t = max(self._t, float(t))

    def _rhs(self, _t, y):
        return [*y[3:], *self._accel(y[:3], y[3:], (0.0, 0.0, 0.0))]

    def _transition(self, dt):
        key = round(dt, 9)
        cached = self._transitions.get(key)
        if cached is None:
            phi, q = np.eye(9), np.zeros((9, 9))
            phi[:6, :6] = cw_transition_matrix(self.n, dt)  # seed 000 eq 22
            q[:6, :6] = white_accel_q(self.config.accel_psd_m2_s3, dt)
            cached = (phi, q)
            put_bounded(self._transitions, key, cached, MAX_TRANSITIONS)
        return cached

    def add_thrust(self, t_start, t_end, dv_hill, covariance):
        """A thrust's delta-v [m/s, hill] over [t_start, t_end] (a constant acceleration) with its 3x3 covariance: a
        known input, at or before the filter time."""
        g = np.vstack((0.5 * (t_end - t_start) * _I3, _I3))  # [T/2 I; I]
        if self._t > t_end:
            g = cw_transition_matrix(self.n, self._t - t_end) @ g  # seed 000 eq 22
        self._x_ref = (np.asarray(self._x_ref) + g @ np.asarray(dv_hill, dtype=float)).tolist()
        g9 = np.vstack((g, np.zeros((3, 3))))
        self.covariance = self.covariance + g9 @ np.asarray(covariance, dtype=float) @ g9.T

    def update(self, t, y_chaser_hill, c_hill_from_body, estimate_p=True):
        """The relative position of the chaser's CoM at t [m, hill] with the attitude estimate then: propagated,
        gated (chi2(3) on the NIS) and fused (Joseph form); an agreeing run of rejections restarts the position
        from the measurement. estimate_p False: p a consider parameter (Schmidt): its uncertainty weighs the
        update, but it and its covariance stay. Returns the ``filter_interface.UpdateResult``."""
        self.propagate_to(t)
        c = np.asarray(c_hill_from_body, dtype=float)
        y = np.asarray(y_chaser_hill, dtype=float)
        innovation = y - np.asarray(self._x_ref[:3]) - c @ self.p
        h = np.hstack((_I3, np.zeros((3, 3)), c))
        ph = self.covariance @ h.T
        s = h @ ph + self._r
        s_inv = np.linalg.inv(s)
        nis = float(innovation @ s_inv @ innovation)
        verdict = self._gate_verdict(nis, t, lambda: (innovation,))
        if verdict == 'reset':
            self._restart(y, c)
        if verdict != 'pass':
            return self._outcome(verdict, t, nis, innovation=innovation)
        k = ph @ s_inv
        if not estimate_p:
            k[6:] = 0.0
        delta = k @ innovation
        self._x_ref = (np.asarray(self._x_ref) + delta[:6]).tolist()
        self.p = self.p + delta[6:]
        i_kh = np.eye(9) - k @ h
        p = i_kh @ self.covariance @ i_kh.T + k @ self._r @ k.T
        self.covariance = 0.5 * (p + p.T)
        return self._outcome('accepted', t, nis, innovation=innovation)

    def _restart(self, y, c):
        """Lost: the position from the measurement, the velocity at its prior's sigma at least, p and its covariance
        kept."""
        p_v = self.covariance[3:6, 3:6]
        floor = self.config.initial_velocity_sigma_mps**2
        p_v = p_v + np.diag(np.maximum(floor - np.diag(p_v), 0.0))
        velocity = self._x_ref[3:]
        self.initialize(self._t, y, c)
        self._x_ref[3:] = velocity
        self.covariance[3:6, 3:6] = p_v

    def velocity_sigma_mps(self):
        """The combined CoM's velocity 1-sigma [m/s], its largest direction."""
        return float(math.sqrt(max(float(np.max(np.linalg.eigvalsh(self.covariance[3:6, 3:6]))), 0.0)))
