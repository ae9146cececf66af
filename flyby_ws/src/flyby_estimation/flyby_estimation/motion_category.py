"""The target's motion categories I-IV of seed 000 section 2.1 from its estimated rate and attitude excursion.

Pure numpy, no ROS. Frames and rates as ``attitude_error_dynamics``: omega_hill the inertial rate in hill axes.
"""

import dataclasses
import math

import numpy as np

from flyby_estimation.target_motion import orbit_rate_hill
from flyby_msgs_py import params
from flyby_sim.dynamics.checks import require_positive


@params.record
class MotionThresholds:
    """Thresholds of classify_motion, the scenario's ``estimation`` keys (flyby_msgs_py.params; the schema's
    defaults are from seed 000 section 2.1).

    Attributes:
        spin_rate_rad_s: inertial rate at and above which the target is category IV (spinning).
            The schema's 18 deg/s is a 20 s rotation period: the paper gives 20-3600 s as the period range
            of categories II and III, the fly-by cases.
        hill_fixed_rate_rad_s: rate relative to the hill frame below which the attitude counts as
            held in hill (categories I, II). The schema's 0.1 deg/s is a 3600 s period, the slow end of
            the paper's range.
        inertial_hold_rate_rad_s: inertial rate below which the target counts as held in inertial
            space (category I, e.g. sun pointing).
        controlled_rate_rad_s: rate relative to hill below which a hill-held target counts as
            three-axis controlled (I) rather than librating under gravity gradient (II).
            The schema's 0.01 deg/s: a 10 deg gravity-gradient libration at sqrt(3) n (LEO) moves at
            about 0.1 deg/s peak.
        controlled_excursion_rad: largest attitude excursion in hill over the observation window
            for category I (when known). The schema's 2 deg: gravity-gradient librations are larger.
    """

    spin_rate_rad_s: float = params.key('estimation.spin_rate_deg_s', math.radians)
    hill_fixed_rate_rad_s: float = params.key('estimation.hill_fixed_rate_deg_s', math.radians)
    inertial_hold_rate_rad_s: float = params.key('estimation.inertial_hold_rate_deg_s', math.radians)
    controlled_rate_rad_s: float = params.key('estimation.controlled_rate_deg_s', math.radians)
    controlled_excursion_rad: float = params.key('estimation.controlled_excursion_deg', math.radians)

    def __post_init__(self):
        for field in dataclasses.fields(self):
            require_positive(field.name, getattr(self, field.name))


@dataclasses.dataclass(frozen=True)
class MotionCategory:
    """Result of classify_motion: category 'I'..'IV' of seed 000 section 2.1 and a one-line reason."""

    category: str
    reason: str
    inertial_rate_rad_s: float
    hill_relative_rate_rad_s: float


CATEGORY_NAMES = {
    'I': 'three-axis controlled',
    'II': 'gravity-gradient stabilized',
    'III': 'slowly tumbling',
    'IV': 'spinning',
}


def classify_motion(omega_hill, n, thresholds, attitude_excursion_rad=None):
    """Category I-IV of the target motion (seed 000 section 2.1, Fig. 2).

    Decision, in order:
      IV  |omega| >= spin_rate (rotation period under 20 s): synchronized approach, not fly-by.
      I   |omega| < inertial_hold_rate: attitude held in inertial space.
      III |omega - Omega^H| >= hill_fixed_rate: slowly tumbling relative to the orbit frame.
      I   held in hill with |omega - Omega^H| < controlled_rate and (if known) an attitude
          excursion < controlled_excursion: three-axis controlled (e.g. Earth pointing).
      II  otherwise held in hill, librating: gravity-gradient stabilized.

    Args:
        omega_hill: inertial angular velocity in hill axes [rad/s] (seed 000 eq 6).
        n: orbital mean motion [rad/s].
        attitude_excursion_rad: largest attitude change in hill over the observation window, or None.
        thresholds: MotionThresholds.
    """
    w = np.asarray(omega_hill, dtype=float)
    if w.shape != (3,) or not np.all(np.isfinite(w)):
        raise ValueError(f'omega_hill must be 3 finite values [rad/s], got {omega_hill!r}')
    th = thresholds
    rate = float(np.linalg.norm(w))
    rel = float(np.linalg.norm(w - orbit_rate_hill(n)))

    def result(category, why):
        return MotionCategory(category, f'{CATEGORY_NAMES[category]}: {why}', rate, rel)

    deg = math.degrees
    if rate >= th.spin_rate_rad_s:
        return result('IV', f'inertial rate {deg(rate):.3g} deg/s >= {deg(th.spin_rate_rad_s):.3g} deg/s '
                            f'(period {2 * math.pi / rate:.3g} s)')
    if rate < th.inertial_hold_rate_rad_s:
        return result('I', f'inertial rate {deg(rate):.3g} deg/s < {deg(th.inertial_hold_rate_rad_s):.3g} deg/s '
                           '(held in inertial space)')
    if rel >= th.hill_fixed_rate_rad_s:
        return result('III', f'rate relative to hill {deg(rel):.3g} deg/s >= {deg(th.hill_fixed_rate_rad_s):.3g} '
                             f'deg/s (period {2 * math.pi / rel:.3g} s)')
    excursion_ok = attitude_excursion_rad is None or attitude_excursion_rad < th.controlled_excursion_rad
    excursion = 'unknown' if attitude_excursion_rad is None else f'{deg(attitude_excursion_rad):.3g} deg'
    if rel < th.controlled_rate_rad_s and excursion_ok:
        return result('I', f'rate relative to hill {deg(rel):.3g} deg/s < {deg(th.controlled_rate_rad_s):.3g} '
                           f'deg/s, attitude excursion {excursion} (held in hill)')
    return result('II', f'rate relative to hill {deg(rel):.3g} deg/s, attitude excursion {excursion} '
                        '(librating about the hill attitude)')
