"""The chaser's attitude in the fly-by: body +x pointed at the target's centre of mass on
the reaction wheels, the wheels' momentum dumped by the thrusters outside the restriction sphere only.

Pure numpy, no ROS: the guidance node and the headless loop call ``AttitudeGuidance.command`` once per control
period with the chaser's estimates and apply its output one period later (DESIGN section 10).

Frames and conventions. Quaternions (x, y, z, w), scalar last (``flyby_sim.dynamics.rotation``).
``q_hill_from_body`` is the chaser's attitude in ``hill``, ``q_hill_from_goal`` the goal's. ``hill`` is seed
000's frame (``flyby_sim.dynamics.orbital``): x along-track, y orbit anti-normal, z toward Earth, origin at
the target's centre of mass; it turns relative to inertial space at Omega = (0, -n, 0) in its own axes (about
-y, seed 000 eq 11). r_hill, v_hill: the chaser's position and its velocity relative to the rotating frame,
hill axes. Every angular velocity is INERTIAL: ``omega_body`` in body axes, ``omega_goal`` in goal axes, as
the rigid-body equations need it (``rigid_body``); the attitudes are in hill, the error between them does
not depend on the frame (``attitude_control``).

**Pointing goal** (``LineOfSightGoal``). Goal +x along the line of sight u = -r / |r| (the chaser to the
target's centre of mass). The line of sight turns relative to hill at (the angular velocity of a unit
vector, perpendicular to it, is u x u'; the line-of-sight rate of proportional navigation, e.g. Zarchan,
Tactical and Strategic Missile Guidance, AIAA, ch. 2)

.. math::

    \\omega_{los} = u \\times \\dot u = \\frac{r \\times v}{|r|^2}, \\qquad
    \\dot\\omega_{los} = \\frac{r \\times a}{|r|^2} - 2 \\frac{r \\cdot v}{|r|^2} \\omega_{los}

with a the relative acceleration: Clohessy-Wiltshire coasting (seed 000 eq 2) unless the caller gives it
(a burn). The roll about the line of sight does not matter to the pointing; the rule:

* the goal frame is carried along the line of sight by the smallest rotation (parallel transport: no roll
  rate of its own, so the goal's rate relative to hill is omega_los alone, the least the wheels can do),
  which is continuous for any motion of the line of sight;
* its roll relaxes toward "goal z as close as possible to hill z" (toward Earth): a roll rate
  w sat(phi / tau_roll, omega_roll_max) about u, phi the angle from goal z to hill z's projection
  perpendicular to u, w = |u x z_hill|^2 the squared sine of the angle between u and hill z. A fixed rule
  alone cannot be continuous (no continuous tangent field on the sphere: hill z's projection flips as the
  line of sight crosses R-bar, where a fly-by past the target often looks); w fades the rule out at that
  singularity, where the roll is simply carried along;
* the first goal (or the first after a gap in the calls of more than ``max_gap_s``) is the chaser's own
  estimated attitude carried onto the line of sight by the smallest rotation (``AttitudeGuidance``: no roll
  slew at acquisition; the relaxation then turns the roll slowly to the rule), or the rule's attitude where no
  attitude is given (``LineOfSightGoal.update``).

The goal's inertial angular velocity and acceleration (hill axes, then turned into goal axes), the
inertial derivative of Omega + omega_rel being d/dt|hill omega_rel + Omega x omega_rel (Omega constant):

.. math::

    \\omega_g = \\Omega + \\omega_{los} + \\omega_{roll} u, \\qquad
    \\dot\\omega_g = \\dot\\omega_{los} + \\omega_{roll} (\\omega_{los} \\times u)
                     + \\Omega \\times (\\omega_{los} + \\omega_{roll} u)

(the roll rate's own slow change is not fed forward).

**Tracking** on the wheels: ``attitude_control.QuaternionFeedbackController.body_torque`` with that goal (its
module doc: the rate-limited quaternion feedback of Wie and Lu 1995 with gyroscopic compensation and the
feed-forward I (C omega_dot_g - omega x C omega_g) of Wen and Kreutz-Delgado 1991), so a turning line of
sight is followed without lag.

**Momentum dumping** (the classic unloading law, e.g. Markley and Crassidis 2014, ch. 7; Wie, Space Vehicle
Dynamics and Control, AIAA: an external torque against the wheels' stored momentum while the wheels hold the
attitude). With H_w = A h, the wheels' momentum in body axes: outside the restriction sphere, from the
moment |H_w| exceeds ``dump_start_n_m_s`` until every body axis is within ``dump_stop_n_m_s``, each axis i
with |H_w,i| > dump_stop gets the thruster torque

.. math::

    \\tau_{thr,i} = -\\mathrm{sign}(H_{w,i}) \\, \\mathrm{clip}(k_{dump} |H_{w,i}|, \\tau_{min}, \\tau_{max})

and the wheels take tau - tau_thr (u = -A^+ (tau - tau_thr), so the body still feels the control torque tau
and h' = u = ... - k A^+ H_w drains the wheels). tau_min: a thruster fires only an impulse above its minimum
impulse bit (``actuators.fire``), so a smaller torque would be commanded, compensated by the wheels, and never
delivered; the default layout makes a pure couple with two thrusters at 0.25 m (0.25 N m per newton each),
each of which must give 0.01 N s in the 0.1 s period: tau_min = 2 x 0.25 m x 0.01 N s / 0.1 s = 0.05 N m,
also the default tau_max (half the default wheels' 0.1 N m), so at this period the dump is bang-bang. The
dumping only uses the wheels' torque headroom: if the control torque plus the dump's share would exceed a
wheel's limit, the dump is scaled down (and an axis below tau_min dropped), pointing first. Inside the
restriction sphere the thruster torque is exactly zero and dumping stops (no thruster fires there,
attitude control included: seed 000 section 4.1).

**Wheels taken out** (``take_wheels_out``: a wheel fault's ``reallocate``, docs/faults.md). A failed wheel (no
motor torque, or less than commanded, or a runaway's torque of its own) is commanded nothing from then on: the wheels
left take the control torque's part in their span, u = -A_k^+ tau with A_k the axis matrix with the out wheels'
columns zero (its pseudo-inverse has their rows zero); the rest, (1 - A_k A_k^+) tau (with three orthogonal wheels,
the torque about the lost wheel's axis), goes to the thrusters' couples (the plant allocates the commanded torque on
its thrusters, ``actuators.allocate_wrench``, as the dump's), pulse-modulated: that part's angular impulse is carried
from period to period and fired once it is worth ``axis_pulse_n_m_s`` (``damping.pulse_modulated``; a couple below
the minimum impulse bit would not be fired at all, and the axis's mean torque would be lost). The PD law's error on
that axis then cycles within a few pulses' rate (0.01 N m s / 10 kg m^2 = 1e-3 rad/s for paper_flyby_6dof's
chaser). Inside the restriction sphere no thruster fires: the axis is left to its own motion, and what was carried
is dropped. The dump takes out only the momentum of the wheels left, A_k h (an out wheel's is no longer the
control's; A_k A_k^+ A h would keep it wherever the wheels left span its axis, as on a four-wheel pyramid). How many
wheels may go: ``take_wheels_out`` refuses (ValueError, ``wheels_out_refusal``) a further wheel once the wheels left
span fewer than three axes. The law itself would give any number of axes to the thrusters, but inside the
restriction sphere each such axis has no torque at all, so one lost axis is the most the approach is flown with: on
three orthogonal wheels the first loss is taken, the second refused; on a four-wheel pyramid the first two. An index
that is no wheel is refused the same way (guidance reports either as an ERROR event, ``modes.chaser``). A
runaway wheel, commanded nothing, still turns the body by its own torque: the same feedback on the thrusters holds
against it outside the sphere (its steady error d / (k_p J) for a torque d), until the plant stops it at its momentum
limit; guidance's account of its momentum (what it commanded) is then wrong in the gyroscopic term.

**Integral action** (``integral_time_s``, off by default; the synchronized approach's hold sets it): a constant
disturbance torque d (the thrusters' errors under a force held in the body) leaves the proportional-derivative
law a steady error e = d / (k_p J). ``track`` adds -(k_p / T_i) J integral(e dt), the error integrated over the control
periods of the same goal, each axis's term clamped to ``integral_max_torque_n_m`` (anti-windup); the closed
loop s^3 + k_d s^2 + k_p s + k_p / T_i is stable for T_i > 1 / k_d (T_i 10 s at omega_n 2.5 rad/s: the poles move
by a few percent).
"""

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from flyby_guidance.damping import pulse_modulated
from flyby_sim.dynamics.attitude_control import (
    QuaternionFeedbackController,
    attitude_error_rotation_vector,
    cross3,
    pointing_error_rad,  # noqa: F401  (re-exported: the mission's figure lives with the control law)
)
from flyby_sim.dynamics.checks import require_positive
from flyby_sim.dynamics.orbital import cw_accel_components, quat_eci_from_hill
from flyby_sim.dynamics.rigid_body import ChaserAttitudeState
from flyby_sim.dynamics.rotation import (
    quat_conjugate,
    quat_from_axis_angle,
    quat_from_matrix,
    quat_multiply,
    quat_normalize,
    quat_rotate,
    quat_shortest_arc,
    quat_to_matrix,
    random_small_rotation,
)

_HILL_Z = (0.0, 0.0, 1.0)


@dataclasses.dataclass(frozen=True)
class AttitudeGuidanceConfig:
    """Attitude control settings of the fly-by (module doc), every one with its unit.

    The gains and rate limit are those of docs/chaser_6dof.md's slew (omega_n 0.2 rad/s, zeta 1,
    omega_max 0.05 rad/s); the dump floor assumes the default thruster layout and this control period.
    """

    natural_frequency_rad_s: float = 0.2  # omega_n; k_p = omega_n^2, k_d = 2 zeta omega_n
    damping_ratio: float = 1.0  # zeta
    max_rate_rad_s: float = 0.05  # rate limit relative to the goal
    control_period_s: float = 0.1  # [s] commands held this long (zero-order hold), applied one period late
    roll_time_constant_s: float = 100.0  # [s] tau_roll: the goal's roll relaxes toward the rule
    max_roll_rate_rad_s: float = 0.005  # omega_roll_max (0: roll carried, never relaxed)
    max_gap_s: float = 10.0  # [s] calls further apart restart the goal (from the chaser's attitude)
    dump_start_n_m_s: float = 1.0  # |A h| above which dumping starts (outside the sphere)
    dump_stop_n_m_s: float = 0.2  # each body axis dumps down to this
    dump_gain_per_s: float = 0.05  # k_dump
    dump_min_torque_n_m: float = 0.05  # tau_min: 2 x lever arm x minimum impulse bit / control period
    dump_max_torque_n_m: float = 0.05  # tau_max per axis (half the default wheels' 0.1 N m)
    integral_time_s: float = None  # [s] T_i of the integral action of ``track`` (None: none)
    integral_max_torque_n_m: float = 1.0  # its term's clamp per body axis
    # [N m s] a wheel-less axis's thruster torque fired in pulses of this angular impulse (module doc): four minimum
    # impulse bits (0.01 N s) at the default layout's 0.25 m, as the damping's pulse (damping.DAMPING_PULSE_BITS)
    axis_pulse_n_m_s: float = 0.01

    def __post_init__(self):
        for name in ('natural_frequency_rad_s', 'damping_ratio', 'max_rate_rad_s', 'control_period_s',
                     'roll_time_constant_s', 'max_gap_s', 'dump_start_n_m_s', 'dump_gain_per_s',
                     'dump_max_torque_n_m', 'axis_pulse_n_m_s'):
            require_positive(name, getattr(self, name))
        for name in ('max_roll_rate_rad_s', 'dump_stop_n_m_s', 'dump_min_torque_n_m'):
            require_positive(name, getattr(self, name), allow_zero=True)
        if self.dump_stop_n_m_s >= self.dump_start_n_m_s:
            raise ValueError(f'dump_stop_n_m_s {self.dump_stop_n_m_s} must be below dump_start_n_m_s '
                             f'{self.dump_start_n_m_s}')
        if self.integral_time_s is not None:
            require_positive('integral_time_s', self.integral_time_s)
            require_positive('integral_max_torque_n_m', self.integral_max_torque_n_m)
        if self.dump_min_torque_n_m > self.dump_max_torque_n_m:
            raise ValueError(f'dump_min_torque_n_m {self.dump_min_torque_n_m} exceeds dump_max_torque_n_m '
                             f'{self.dump_max_torque_n_m}')


class LineOfSight(NamedTuple):
    """The line of sight from the chaser to the hill origin and its motion relative to hill (hill axes)."""

    u_hill: np.ndarray  # (3,) unit, -r / |r|
    omega_hill_rad_s: np.ndarray  # (3,) r x v / |r|^2, relative to hill
    omega_dot_hill_rad_s2: np.ndarray  # (3,) its derivative in hill


def line_of_sight(r_hill, v_hill, n, a_hill=None):
    """LineOfSight of a chaser at r_hill [m] moving at v_hill [m/s] (relative to hill), module doc; a_hill
    [m/s^2]: its relative acceleration (None: CW coasting at mean motion n [rad/s], seed 000 eq 2)."""
    r = np.asarray(r_hill, dtype=float)
    v = np.asarray(v_hill, dtype=float)
    rho2 = float(r @ r) if r.shape == (3,) else math.nan
    if v.shape != (3,) or not (math.isfinite(rho2) and rho2 > 0.0) or not np.all(np.isfinite(v)):
        raise ValueError(f'r_hill {r_hill!r} must be finite and nonzero and v_hill {v_hill!r} finite (3 values)')
    if a_hill is None:
        a = np.array(cw_accel_components(r.tolist(), v.tolist(), n))
    else:
        a = np.asarray(a_hill, dtype=float)
        if a.shape != (3,) or not np.all(np.isfinite(a)):
            raise ValueError(f'a_hill must be 3 finite values [m/s^2], got {a_hill!r}')
    omega = cross3(r, v) / rho2
    omega_dot = cross3(r, a) / rho2 - (2.0 * float(r @ v) / rho2) * omega
    return LineOfSight(-r / math.sqrt(rho2), omega, omega_dot)


def roll_rule_attitude(u_hill, reference_hill=_HILL_Z):
    """q_hill_from_goal with goal x along u_hill and goal z as close as possible to reference_hill (to the hill
    axis least along u_hill when u_hill lies along the reference)."""
    x = np.asarray(u_hill, dtype=float)
    x = x / np.linalg.norm(x)
    ref = np.asarray(reference_hill, dtype=float)
    z = ref - (ref @ x) * x
    if np.linalg.norm(z) < 1e-6 * np.linalg.norm(ref):  # along the reference: the hill axis least along u
        axis = np.eye(3)[int(np.argmin(np.abs(x)))]
        z = axis - (axis @ x) * x
    z /= np.linalg.norm(z)
    return quat_from_matrix(np.column_stack((x, cross3(z, x), z)))


class PointingGoal(NamedTuple):
    """A goal attitude with its feed-forward (module doc)."""

    q_hill_from_goal: np.ndarray  # (4,)
    omega_goal: np.ndarray  # (3,) inertial angular velocity [rad/s], goal axes
    omega_dot_goal: np.ndarray  # (3,) its inertial derivative [rad/s^2], goal axes
    u_hill: np.ndarray  # (3,) line of sight (goal +x), hill axes
    roll_rate_rad_s: float  # the rule's roll rate about u


def hold_goal(q_hill_from_goal, n):
    """PointingGoal of an attitude held fixed in hill: it turns with hill (Omega = (0, -n, 0)), no acceleration."""
    q = quat_normalize(q_hill_from_goal)
    omega_goal = quat_rotate(quat_conjugate(q), (0.0, -n, 0.0))
    return PointingGoal(q, omega_goal, np.zeros(3), quat_rotate(q, (1.0, 0.0, 0.0)), 0.0)


class LineOfSightGoal:
    """The pointing goal along the line of sight, its roll carried and relaxed toward the rule (module doc).

    Stateful: each ``update`` carries the previous goal to the new line of sight. The same calls give the
    same goals (nothing else is kept).
    """

    def __init__(self, reference_hill=_HILL_Z, roll_time_constant_s=100.0, max_roll_rate_rad_s=0.005,
                 max_gap_s=10.0):
        ref = np.asarray(reference_hill, dtype=float)
        if ref.shape != (3,) or not np.all(np.isfinite(ref)) or not np.any(ref):
            raise ValueError(f'reference_hill must be a finite nonzero 3-vector, got {reference_hill!r}')
        self.reference_hill = ref / np.linalg.norm(ref)
        self.roll_time_constant_s = roll_time_constant_s
        self.max_roll_rate_rad_s = max_roll_rate_rad_s
        self.max_gap_s = max_gap_s
        self.reset()

    def reset(self, q_hill_from_goal=None):
        """Forget the carried goal: the next update starts afresh (``update``), from q_hill_from_goal if given."""
        self._t = self._u = None
        self._q = None if q_hill_from_goal is None else quat_normalize(q_hill_from_goal)
        self._roll_rate = 0.0

    def update(self, t, r_hill, v_hill, n, a_hill=None, q_hill_from_start=None):
        """PointingGoal at time t [s] for the chaser at r_hill, v_hill (a_hill: module doc).

        A fresh start (the first update, or after a gap of more than max_gap_s or a step back in time) takes
        q_hill_from_start (e.g. the chaser's own attitude, to spare a roll slew at acquisition), else the
        attitude given to ``reset``, else the rule's attitude, carried onto the line of sight by the smallest
        rotation.
        """
        los = line_of_sight(r_hill, v_hill, n, a_hill)
        u = los.u_hill
        dt = None if self._t is None else t - self._t
        if dt is None or not (0.0 <= dt <= self.max_gap_s):
            start = q_hill_from_start if q_hill_from_start is not None else self._q if dt is None else None
            if start is None:
                q = roll_rule_attitude(u, self.reference_hill)
            else:
                start = quat_normalize(start)
                q = quat_normalize(quat_multiply(quat_shortest_arc(quat_rotate(start, (1.0, 0.0, 0.0)), u), start))
        else:
            # the smallest rotation from the last line of sight to this one, then the roll commanded then
            q = quat_multiply(quat_shortest_arc(self._u, u), self._q)
            if self._roll_rate != 0.0:
                q = quat_multiply(quat_from_axis_angle(u, self._roll_rate * dt), q)
            q = quat_normalize(q)
        roll_rate = roll_relaxation_rate(q, self.reference_hill, self.roll_time_constant_s,
                                         self.max_roll_rate_rad_s)
        self._t, self._q, self._u, self._roll_rate = t, q, u, roll_rate
        omega_rel = los.omega_hill_rad_s + roll_rate * u
        omega_hill_frame = np.array((0.0, -n, 0.0))  # seed 000 eq 11
        omega_goal_hill = omega_hill_frame + omega_rel
        omega_dot_goal_hill = (los.omega_dot_hill_rad_s2 + roll_rate * cross3(los.omega_hill_rad_s, u)
                               + cross3(omega_hill_frame, omega_rel))
        q_goal_from_hill = quat_conjugate(q)
        return PointingGoal(q, quat_rotate(q_goal_from_hill, omega_goal_hill),
                            quat_rotate(q_goal_from_hill, omega_dot_goal_hill), u, roll_rate)



def roll_relaxation_rate(q_hill_from_goal, reference_hill, roll_time_constant_s, max_roll_rate_rad_s):
    """Roll rate [rad/s] about the goal's +x (u) that turns goal z toward the unit reference_hill's projection
    perpendicular to u: w sat(phi / tau_roll, omega_roll_max), phi the signed angle from goal z to that
    projection about u, w = |u x reference|^2 (module doc)."""
    c = quat_to_matrix(q_hill_from_goal)
    u, z_goal = c[:, 0], c[:, 2]
    ref = np.asarray(reference_hill, dtype=float)
    z_rule = ref - (ref @ u) * u  # length sqrt(w)
    w = float(z_rule @ z_rule)
    if max_roll_rate_rad_s == 0.0 or w == 0.0:
        return 0.0
    phi = math.atan2(float(cross3(z_goal, z_rule) @ u), float(z_goal @ z_rule))
    return w * min(max(phi / roll_time_constant_s, -max_roll_rate_rad_s), max_roll_rate_rad_s)


class AttitudeCommand(NamedTuple):
    """What the attitude control asks for over the next control period."""

    wheel_torque_n_m: np.ndarray  # (N,) motor torques
    thruster_torque_body_n_m: np.ndarray  # (3,) thruster torque about the CoM, chaser_body axes; exactly 0 inside


class AttitudeGuidance:
    """Pointing of body +x at the target's centre of mass on the wheels, momentum dumping outside the
    restriction sphere (module doc).

    After each call: ``goal`` (the PointingGoal used), ``dumping`` (a dump is under way),
    ``body_torque_n_m`` (the control torque asked of wheels and thrusters together) and ``saturated`` (the
    wheel command was scaled down to the wheels' torque limit). ``wheels_out``: the wheels taken out
    (``take_wheels_out``).
    """

    def __init__(self, config, inertia_kg_m2, wheels):
        """config: AttitudeGuidanceConfig; inertia_kg_m2: the chaser's 3x3 inertia without the wheels' spin
        inertia (``rigid_body``); wheels: ReactionWheels."""
        self.config = config
        self.wheels = wheels
        self.controller = QuaternionFeedbackController(inertia_kg_m2, wheels, config.natural_frequency_rad_s,
                                                       config.damping_ratio, config.max_rate_rad_s)
        self.goal_tracker = LineOfSightGoal(_HILL_Z, config.roll_time_constant_s, config.max_roll_rate_rad_s,
                                            config.max_gap_s)
        self.goal = None
        self.error_integral = np.zeros(3)  # [rad s] of the integral action, body axes
        self.dumping = False
        self.saturated = False
        self.body_torque_n_m = np.zeros(3)
        self.wheels_out = frozenset()
        self.axes_left = wheels.axis_matrix  # A_k: the axis matrix, the out wheels' columns zero (module doc)
        self.axes_pinv = self.controller.axes_pinv  # A_k^+ of the wheels left
        self.wheel_span = np.eye(3)  # A_k A_k^+: the body torques the wheels left can give
        self.axis_carried_n_m_s = np.zeros(3)  # the wheel-less axes' angular impulse not yet fired

    def wheels_out_refusal(self, indices, also_out=()):
        """Why taking these wheels out (with ``also_out`` already promised) is refused, or None: a ValueError's text
        naming an index that is no wheel, or the wheels left already short of three axes (module doc: a second
        loss on three orthogonal wheels; the thrusters would then hold two axes, and none inside the sphere)."""
        count = self.wheels.count
        for i in indices:
            if not float(i).is_integer() or not 0 <= int(i) < count:
                return f'wheel index {i} is not one of the {count} wheels (0 to {count - 1})'
        before = self.wheels_out | {int(i) for i in also_out}
        new = {int(i) for i in indices} - before
        if new and np.linalg.matrix_rank(self._axes_left(before)) < 3:
            left = sorted(set(range(count)) - before)
            return (f'wheels {sorted(new)} cannot be taken out: the wheels left {left} already span fewer than '
                    f'three axes')
        return None

    def take_wheels_out(self, indices):
        """Command these wheels (indices into the wheels) nothing from the next call on, their torque to the wheels
        left and the thrusters' couples (module doc). ValueError (``wheels_out_refusal``) for an index that is no
        wheel, or a further wheel once the wheels left span fewer than three axes; nothing changes then."""
        reason = self.wheels_out_refusal(indices)
        if reason is not None:
            raise ValueError(reason)
        self.wheels_out = self.wheels_out | {int(i) for i in indices}
        self.axes_left = self._axes_left(self.wheels_out)
        self.axes_pinv = np.linalg.pinv(self.axes_left)
        self.wheel_span = self.axes_left @ self.axes_pinv

    def _axes_left(self, out):
        """The axis matrix (3, N) with the columns of the wheels ``out`` zero: A_k of the module doc."""
        axes_left = self.wheels.axis_matrix.copy()
        axes_left[:, sorted(out)] = 0.0
        return axes_left

    def command(self, t, q_hill_from_body, omega_body, h_wheels_n_m_s, r_hill, v_hill, n,
                inside_restriction_sphere, a_hill=None):
        """AttitudeCommand pointing body +x at the hill origin.

        Args:
            t: time of the estimates [s].
            q_hill_from_body: estimated attitude (4,).
            omega_body: estimated inertial angular velocity [rad/s], body axes.
            h_wheels_n_m_s: the wheels' momenta (N,) [N m s].
            r_hill, v_hill: estimated relative position [m] and velocity [m/s] (relative to hill), hill axes.
            n: mean motion [rad/s].
            inside_restriction_sphere: True where no thruster may fire (then the thruster torque is exactly 0).
            a_hill: the chaser's relative acceleration [m/s^2] if known (a burn), else CW coasting.
        """
        goal = self.goal_tracker.update(t, r_hill, v_hill, n, a_hill, q_hill_from_start=q_hill_from_body)
        return self.track(goal, q_hill_from_body, omega_body, h_wheels_n_m_s, inside_restriction_sphere)

    def hold(self, q_hill_from_goal, q_hill_from_body, omega_body, h_wheels_n_m_s, n, inside_restriction_sphere):
        """AttitudeCommand holding an attitude fixed in hill (``hold_goal``); the next ``command`` starts its
        pointing goal from the chaser's attitude then."""
        self.goal_tracker.reset()
        return self.track(hold_goal(q_hill_from_goal, n), q_hill_from_body, omega_body, h_wheels_n_m_s,
                          inside_restriction_sphere)

    def track(self, goal, q_hill_from_body, omega_body, h_wheels_n_m_s, inside_restriction_sphere):
        """AttitudeCommand for any PointingGoal: the tracking torque on the wheels, plus the dump."""
        self.goal = goal
        h = np.asarray(h_wheels_n_m_s, dtype=float)
        torque = self.controller.body_torque(q_hill_from_body, omega_body, h, goal.q_hill_from_goal,
                                             goal.omega_goal, goal.omega_dot_goal)
        if self.config.integral_time_s is not None:
            torque = torque + self._integral_torque(q_hill_from_body, goal.q_hill_from_goal)
        self.body_torque_n_m = torque
        thruster_torque = np.zeros(3)
        if inside_restriction_sphere:
            self.dumping = False
            self.axis_carried_n_m_s = np.zeros(3)
        else:
            thruster_torque = self._dump_torque(torque, h) + self._axis_torque(torque)
        wheel_share = torque - thruster_torque if thruster_torque.any() else torque
        self.saturated = bool(np.any(np.abs(self.axes_pinv @ wheel_share) > self.wheels.max_torque_n_m))
        return AttitudeCommand(self.controller.wheel_torque_for(wheel_share, axes_pinv=self.axes_pinv),
                               thruster_torque)

    def _axis_torque(self, torque_body):
        """Thruster torque [N m] (3,) of the part of the control torque no wheel left can give, pulse-modulated
        (module doc; zero with every wheel in)."""
        if not self.wheels_out:
            return np.zeros(3)
        lost = torque_body - self.wheel_span @ torque_body
        pulse, self.axis_carried_n_m_s = pulse_modulated(self.axis_carried_n_m_s, lost,
                                                         self.config.control_period_s, self.config.axis_pulse_n_m_s)
        return pulse

    def _integral_torque(self, q_hill_from_body, q_hill_from_goal):
        """The integral action's torque [N m] (3,), body axes (module doc)."""
        cfg, ctrl = self.config, self.controller
        e = attitude_error_rotation_vector(q_hill_from_body, q_hill_from_goal)
        self.error_integral = self.error_integral + e * cfg.control_period_s
        k_i = ctrl.k_p / cfg.integral_time_s
        limit = cfg.integral_max_torque_n_m
        torque = -k_i * (ctrl.inertia @ self.error_integral)
        clamped = np.clip(torque, -limit, limit)
        if np.any(clamped != torque):  # anti-windup: keep the integral where its term is clamped
            self.error_integral = -np.linalg.solve(ctrl.inertia, clamped) / k_i
        return clamped

    def _dump_torque(self, torque_body, h):
        """Thruster torque [N m] (3,) of the dump within the wheels' headroom (module doc)."""
        cfg = self.config
        h_body = self.axes_left @ h  # the wheels left's momentum only, A_k h (module doc)
        if not self.dumping and float(np.linalg.norm(h_body)) > cfg.dump_start_n_m_s:
            self.dumping = True
        active = np.abs(h_body) > cfg.dump_stop_n_m_s
        if self.dumping and not active.any():
            self.dumping = False
        if not self.dumping:
            return np.zeros(3)
        magnitude = np.clip(cfg.dump_gain_per_s * np.abs(h_body), cfg.dump_min_torque_n_m, cfg.dump_max_torque_n_m)
        dump = np.where(active, -np.sign(h_body) * magnitude, 0.0)
        # headroom: the largest s <= 1 with |u_ctrl + s A^+ dump| <= limit on every wheel (pointing first)
        pinv = self.axes_pinv
        u_ctrl = -pinv @ torque_body
        u_dump = pinv @ dump
        limit = self.wheels.max_torque_n_m
        if np.any(np.abs(u_ctrl) > limit):
            return np.zeros(3)
        scale = 1.0
        for uc, ud, lim in zip(u_ctrl.tolist(), u_dump.tolist(), limit.tolist(), strict=True):
            if ud > 0.0:
                scale = min(scale, (lim - uc) / ud)
            elif ud < 0.0:
                scale = min(scale, (-lim - uc) / ud)
        dump = scale * dump
        return np.where(np.abs(dump) >= cfg.dump_min_torque_n_m, dump, 0.0)  # what the thrusters can deliver


class PointingRun(NamedTuple):
    """Time histories of ``simulate_pointing``, one row per control period (t0 first, the end last)."""

    t_s: np.ndarray  # (K,)
    pointing_error_rad: np.ndarray  # (K,) true body +x against the true line of sight
    q_hill_from_body: np.ndarray  # (K, 4) true
    omega_body: np.ndarray  # (K, 3) true [rad/s]
    h_wheels_n_m_s: np.ndarray  # (K, N)
    wheel_torque_n_m: np.ndarray  # (K - 1, N) applied, mean over each period
    thruster_torque_body_n_m: np.ndarray  # (K - 1, 3) applied
    los_rate_rad_s: np.ndarray  # (K,) |omega_los| of the true path
    saturated_steps: int  # periods whose wheel command the guidance scaled down to the torque limit
    torque_limited_steps: int  # periods in which the propagator clipped a wheel command (none: scaled before)
    momentum_limited_steps: int  # periods in which a wheel sat at its momentum limit

    def percentile_deg(self, q, start_s=-math.inf, end_s=math.inf):
        """The q-th percentile of the pointing error [deg] over start_s <= t <= end_s."""
        window = (self.t_s >= start_s) & (self.t_s <= end_s)
        return math.degrees(float(np.percentile(self.pointing_error_rad[window], q)))


def gravity_gradient_torque(q_hill_from_body, inertia_kg_m2, n):
    """Gravity-gradient torque [N m], body axes, on a body at the hill origin: 3 n^2 c x (I c), c the unit
    vector toward Earth (hill +z) in body axes (the classic gravity-gradient torque 3 mu / R^3 c x I c, e.g.
    Markley and Crassidis 2014, ch. 3, with mu / R^3 = n^2)."""
    c = quat_rotate(quat_conjugate(q_hill_from_body), _HILL_Z)
    return 3.0 * n * n * cross3(c, np.asarray(inertia_kg_m2, dtype=float) @ c)


def simulate_pointing(guidance, propagator, path, t0_s, t1_s, n, rng=None, attitude_sigma_rad=0.0,
                      rate_sigma_rad_s=0.0, delay_periods=1, restriction_sphere_radius_m=0.0,
                      gravity_gradient=True, q_hill_from_body0=None, h_wheels0_n_m_s=None,
                      external_torque_body_n_m=None, estimate=None):
    """Closed-loop pointing along a given relative path: the guidance's commands held over each control period
    (zero-order hold) through a GyrostatPropagator, applied ``delay_periods`` after the estimates they were
    computed from (DESIGN section 10: one period), the thruster torque applied exactly as commanded.

    Args:
        guidance: AttitudeGuidance (its control period is the step).
        propagator: GyrostatPropagator of the true chaser.
        path: callable t -> (r_hill, v_hill), the true relative motion.
        t0_s, t1_s: start and end [s]. n: mean motion [rad/s] (inertial frame: ECI of ``orbital``).
        rng: numpy Generator for the estimation errors (None: none): the attitude estimate is the truth turned
            by a rotation of attitude_sigma_rad per axis, the rate the truth plus rate_sigma_rad_s per axis.
        restriction_sphere_radius_m: inside this (estimated) range the guidance is told no thruster may fire.
        gravity_gradient: add the gravity-gradient torque (held over each period).
        q_hill_from_body0: initial attitude (None: the goal's, at the goal's rate); h_wheels0_n_m_s: initial
            wheel momenta (None: zero).
        external_torque_body_n_m: a further constant body torque [N m] (None: none).
        estimate: callable t -> (r_hill, v_hill), the relative state the guidance is given (None: path's).
    """
    period = guidance.config.control_period_s
    inertia = propagator.inertia
    count = propagator.wheels.count
    r0, v0 = path(t0_s)
    goal0 = LineOfSightGoal(_HILL_Z).update(t0_s, r0, v0, n)
    if q_hill_from_body0 is None:
        q_hill_from_body0, omega0 = goal0.q_hill_from_goal, goal0.omega_goal
    else:
        omega0 = quat_rotate(quat_conjugate(quat_normalize(q_hill_from_body0)),
                             quat_rotate(goal0.q_hill_from_goal, goal0.omega_goal))
    h0 = np.zeros(count) if h_wheels0_n_m_s is None else np.asarray(h_wheels0_n_m_s, dtype=float)
    state = ChaserAttitudeState(quat_multiply(quat_eci_from_hill(t0_s, n), q_hill_from_body0), np.asarray(omega0),
                                h0)
    extra = np.zeros(3) if external_torque_body_n_m is None else np.asarray(external_torque_body_n_m, dtype=float)
    steps = int(round((t1_s - t0_s) / period))
    pending = [AttitudeCommand(np.zeros(count), np.zeros(3))] * delay_periods
    t_hist, err, qs, ws, hs, us, thr, los_rate = [], [], [], [], [], [], [], []
    saturated = limited_torque = limited_momentum = 0
    for k in range(steps + 1):
        t = t0_s + k * period
        r, v = path(t)
        q_hill = quat_multiply(quat_conjugate(quat_eci_from_hill(t, n)), state.q_inertial_from_body)
        t_hist.append(t)
        err.append(pointing_error_rad(q_hill, r))
        qs.append(q_hill)
        ws.append(state.omega_body)
        hs.append(state.h_wheels_n_m_s)
        los_rate.append(float(np.linalg.norm(cross3(r, v))) / float(r @ r))
        if k == steps:
            break
        q_est, omega_est = q_hill, state.omega_body
        if rng is not None:
            q_est = quat_multiply(q_hill, random_small_rotation(rng, attitude_sigma_rad))
            omega_est = state.omega_body + rate_sigma_rad_s * rng.standard_normal(3)
        r_est, v_est = (r, v) if estimate is None else estimate(t)
        inside = float(np.linalg.norm(r_est)) < restriction_sphere_radius_m  # guidance knows the estimate only
        pending.append(guidance.command(t, q_est, omega_est, state.h_wheels_n_m_s, r_est, v_est, n, inside))
        saturated += guidance.saturated
        applied = pending.pop(0)
        torque_ext = applied.thruster_torque_body_n_m + extra
        if gravity_gradient:
            torque_ext = torque_ext + gravity_gradient_torque(q_hill, inertia, n)
        step = propagator.step(state, period, torque_ext, applied.wheel_torque_n_m)
        state = step.state
        us.append(step.wheel_torque_applied_n_m)
        thr.append(applied.thruster_torque_body_n_m)
        limited_torque += bool(step.torque_limited.any())
        limited_momentum += bool(step.momentum_limited.any())
    return PointingRun(np.array(t_hist), np.array(err), np.array(qs), np.array(ws), np.array(hs),
                       np.array(us).reshape(-1, count), np.array(thr).reshape(-1, 3), np.array(los_rate),
                       saturated, limited_torque, limited_momentum)
