"""The independent monitor's own estimate of the target's attitude (``cam_monitor``): the torque-free motion (Euler's
equations on the scenario's inertia) that best fits the last ``FIT_S`` of vision attitudes, by Gauss-Newton on its
attitude and body rate at the window's first sample, from a line through the samples' rotation vectors (the first
fit) or the last fit carried forward. The attitudes are fitted in ECI (hill turns by the mean motion, 2.6 deg over
the 45 s of a window and a horizon). The fit averages the sensor's noise over the window with the motion's own
curvature, which a line through the samples does not follow (docs/faults.md).

Shares nothing with the navigation filter: the samples are the sensor's raw ones.
"""

import math

import numpy as np
from scipy.spatial.transform import Rotation

from flyby_sim.dynamics.attitude import AttitudePropagator
from flyby_sim.dynamics.orbital import q_eci_from_body, q_hill_from_body_many

FIT_S = 30.0
REFIT_S = 1.0
ITERATIONS = 2
GUESS_S = 3.0
MIN_SAMPLES = 5
_DELTA = 1e-5  # the finite differences' step [rad, rad/s]


class TargetAttitudeFit:
    """The torque-free fit of the target's attitude to its vision samples (module doc)."""

    def __init__(self, inertia_kg_m2, mean_motion_rad_s):
        self.inertia = np.asarray(inertia_kg_m2, dtype=float)
        self.n = mean_motion_rad_s
        self.samples = []  # (t, q_eci_from_body)
        self.fit = None  # (t_s, q_eci_from_body at t_s, omega_body at t_s)
        self.t_fit = -math.inf

    def add(self, t, q_hill_from_body):
        """A vision attitude (x, y, z, w) at t [s]."""
        self.samples.append((float(t), np.asarray(q_eci_from_body(float(t), self.n, q_hill_from_body), dtype=float)))
        while self.samples and self.samples[0][0] < t - FIT_S - 1e-9:
            self.samples.pop(0)

    @property
    def ready(self):
        return len(self.samples) >= MIN_SAMPLES

    def q_hill_at(self, t_now, times):
        """The target's attitude in hill (N, 4) at the non-decreasing times [s] (at or after the window's start),
        refitted where the last fit is older than REFIT_S at t_now."""
        if t_now >= self.t_fit + REFIT_S - 1e-9 or self.fit is None:
            self._refit()
            self.t_fit = t_now
        q_eci, _ = self._propagate(self.fit, times)
        return q_hill_from_body_many(times, self.n, q_eci)

    def _refit(self):
        times = np.array([t for t, _ in self.samples])
        measured = Rotation.from_quat(np.array([q for _, q in self.samples]))
        if self.fit is not None and self.fit[0] <= times[0]:  # the last fit carried forward
            q_s, omega_s = (x[0] for x in self._propagate(self.fit, times[:1]))
            self.fit = self._gauss_newton(times, measured, q_s, omega_s)
            return
        recent = times >= min(times[-1] - GUESS_S, times[-3])  # a line holds over seconds; the fit carries it back
        q_r, omega_r = _line(times[recent], measured[recent])
        t_r, q_r, omega_r = self._gauss_newton(times[recent], measured[recent], q_r, omega_r)
        q_back, omega_back = (x[0] for x in self._propagate((-t_r, q_r, -omega_r), [-times[0]]))  # reversed: -omega
        self.fit = self._gauss_newton(times, measured, q_back, -omega_back)

    def _gauss_newton(self, times, measured, q_s, omega_s):
        """(times[0], q_eci_from_body, omega_body) after ITERATIONS steps from (q_s, omega_s) at times[0]."""
        for _ in range(ITERATIONS):
            base = self._residuals(times, measured, q_s, omega_s)
            columns = []
            for k in range(6):
                step = np.zeros(6)
                step[k] = _DELTA
                q_k, w_k = _perturbed(q_s, omega_s, step)
                columns.append((self._residuals(times, measured, q_k, w_k) - base) / _DELTA)
            correction, *_ = np.linalg.lstsq(np.column_stack(columns), -base, rcond=None)
            q_s, omega_s = _perturbed(q_s, omega_s, correction)
        return float(times[0]), q_s, omega_s

    def _propagate(self, state, times):
        """(q_eci_from_body (N, 4), omega_body (N, 3)) at times from state (t, q, omega)."""
        t_s, q_s, omega_s = state
        return AttitudePropagator(q_s, omega_s, self.inertia, t0=float(t_s), rtol=1e-9,
                                  atol=1e-11).states_at(np.asarray(times, dtype=float))

    def _residuals(self, times, measured, q_s, omega_s):
        """The measured attitudes against the motion from (q_s, omega_s) at times[0], rotation vectors (3 N,)."""
        q, _ = self._propagate((times[0], q_s, omega_s), times)
        return (measured * Rotation.from_quat(q).inv()).as_rotvec().ravel()


def _line(times, measured):
    """A line through the rotation vectors about the last sample: (q_eci_from_body, omega_body) at times[0]."""
    ref = measured[-1]
    design = np.column_stack((np.ones_like(times), times - times[0]))
    coef, *_ = np.linalg.lstsq(design, (measured * ref.inv()).as_rotvec(), rcond=None)
    q0 = Rotation.from_rotvec(coef[0]) * ref
    return q0.as_quat(), q0.inv().apply(coef[1])


def _perturbed(q_eci_from_body, omega_body, step):
    """The state turned by step[:3] [rad, ECI] and its rate moved by step[3:] [rad/s, body]."""
    q = (Rotation.from_rotvec(step[:3]) * Rotation.from_quat(q_eci_from_body)).as_quat()
    return q, np.asarray(omega_body, dtype=float) + step[3:]
