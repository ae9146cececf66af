"""The chaser's health monitors: each sensor's staleness and innovations, and the thrusters' force against the
accelerometer (docs/faults.md). Pure numpy/scipy: the estimator core feeds it what its filters see and publishes
its outputs (``Diagnostics`` on /diagnostics, ``fault_detected`` and ``fault_recovered`` on /mission/events).

Each monitor has a stated rule:

* **Staleness** (every sensor the chaser has), by the receiver's time: the latest stamp judged (the estimator acts
  on stamps, not on a clock; judged at every input's stamp). A sample is fresh where it arrives within
  ``STALE_PERIODS`` of the sensor's periods of its stamp by that time. ``sensor_stale`` where no sample came for
  ``STALE_PERIODS`` periods, or one arrived older than that: a delayed stream's late samples are no proof the sensor
  is fresh (judging the silence alone, a delay beyond the bound raised and cleared a detection at every sample: 299
  over a 30 s delay of the relative position). Cleared once its last ``FRESH_SAMPLES`` samples arrived fresh: at a
  dropout's first sample after it (the ones before it were fresh), a delayed stream ``FRESH_SAMPLES`` periods after
  its samples come fresh again. A delay at the bound, its samples fresh or late at even odds, clears by chance once
  in about 1e6 samples (with 5 samples: 92 detections over 590 s at 10 Hz). The IMU's star tracker is judged at the
  IMU's samples; the wheels' tachometers (``tachometers``, one sample with each IMU sample, at its rate) at theirs:
  their only reader is the wheel monitor, which judges no window without them.
* **Innovations** (relative position, target attitude, star tracker; the relative position's not during a firing
  the navigation filter models nor ``THRUST_SETTLE_S`` after it, while its execution error settles): among the
  sensor's last ``WINDOW`` samples,
  ``OUTLIER_BURST`` or more rejected by the filter's gate (``sensor_outliers``), or the mean NIS of the accepted
  ones above the chi-square bound of ``WINDOW`` samples at a false-alarm probability ``NIS_FALSE_ALARM``
  (``sensor_inconsistent``: a bias, a drift the filter does not model; a gyro's bias jump shows in the star
  tracker's innovations).
* **Thrust** (the rigid-body chaser's accelerometer): each IMU interval's measured velocity change against the one
  the commands lead the navigation filter to expect (guidance's force commands and the burns it models), judged
  one interval late (a command may come after its interval's sample); a force command's shortfall along itself
  is the allocation's (the minimum impulse bit, saturation), taken out. Over the last ``THRUST_WINDOW`` intervals
  the mean residual beyond ``THRUST_SIGMAS`` of the accelerometer's noise on that mean, plus the thrusters'
  specified errors at 3 sigma and ``THRUST_RELATIVE`` of the expected thrust (the attitude estimate a burn is
  turned by: the plant's burn is fixed in the body at its start and turns with it, so the filter's burn, fixed in
  hill, is turned by the attitude estimate's change since), an allowance for the burns' timing, plus
  ``thrust_book.BIT_THRUSTERS`` minimum impulse bits over a control period where a wrench is commanded. Which
  thruster and which kind, by a hypothesis per thruster (``thrust_isolation``: a leak, present whether or not it is
  commanded, against off or weak, present only where it is, each fitted to the window's residual series from the
  commands as the plant allocates them): ``thrust_excess`` (a thruster stuck on) or ``thrust_deficit`` (off or
  weak) naming the thrusters whose hypothesis explains it (at the first thrust detection: its answer may close
  thrusters the hypotheses' allocation does not know of). Where none does alone, by direction: ``thrust_excess``
  where the residual exceeds the expected thrust, else ``thrust_deficit``, with the thrusters whose force lies
  within ``ISOLATION_DEG`` of the residual (or against it, for a deficit) as the candidates.

  The burns' timing: a burn's edge off the filter's (the plant starts a command that reaches it late on its
  arrival) moves its impulse into the neighbouring interval, which changes the window's mean only where it crosses
  the window's ends. So the allowance is the whole acceleration of each edge in the window's first or last interval
  or the one before it, and of every edge of a burn not wholly inside the window; a burn that starts and ends
  inside it needs none. (An allowance at every edge, as before, hid a thruster off through a trim burn shorter
  than an interval: campaign faults_single runs 413, 166 and 259, whose trims fired the failed thruster for 10-230
  ms, missed it and did not capture.)

  Accelerometer outliers: a thruster's force persists (a thruster stuck on leaks the same force from its onset on; one
  off or weak lacks thrust only where it was commanded), while an outlier is one sample off in a random direction. So
  an interval whose residual is more than its expected thrust could lack (beyond ``THRUST_SIGMAS`` of one sample's
  noise and its allowances, a burn's edge in it or next to it included) is thrust no command asked for, a leak, only
  in a run of ``LEAK_INTERVALS`` consecutive such intervals each within ``STEADY_SIGMAS`` of the two samples' noise
  (and their allowances) of the one before; any other is an outlier, left out of the window's mean, and a window with
  fewer than half its intervals left is not judged (neither raised nor cleared). A steady leak breaks such a run with
  probability 1e-3 a pair (a chi(3) bound: it only delays its detection), while random outliers of 20 sigma line up
  for four intervals about once in 1e5 (no thrust detection in 400 simulated 10 s bursts; of 10 sigma, 4 in 400:
  docs/faults.md gives the command, at 3c802a9). A leak is then seen ``LEAK_INTERVALS`` intervals after its onset;
  while the outliers last, not at all. (Without it, a burst of 20-sigma outliers was taken for a thruster stuck on:
  faults_double run 61.) The outliers it leaves out are the accelerometer's, whose only witness this is (the IMU's own
  monitor has no innovations): ``OUTLIER_BURST`` or more settled ones in the window, each in a run no later interval
  can lengthen into a leak (not one still open at the window's end: a leak's onset), are ``sensor_outliers`` on
  ``imu``.

* **Wheels** (the rigid-body chaser's tachometers and gyro): each wheel's axial momentum J (spin + axis . gyro rate)
  changes by the impulse of its motor torque, so over the last ``WHEEL_WINDOW`` paired samples, judged one sample
  late (a command is known by then), the change against guidance's commands (held from their stamps, clipped to
  the motor's limit) beyond ``THRUST_SIGMAS`` of the two samples' noise plus ``WHEEL_RELATIVE`` of the commanded
  impulse: ``wheel_torque_deficit`` where the wheel gave less than commanded (failed, torque-limited),
  ``wheel_torque_excess`` otherwise, naming the wheel. A wheel within ``WHEEL_SATURATION`` of its momentum limit at
  either end is not judged (the plant stops it there), nor are the wheels while the arm grasps (CAPTURE, GRASP: the
  grasp's dynamics hold them).

A detection is cleared after ``CLEAR_WINDOWS`` windows within its rule's bound. The monitors' statuses go out every
``DIAGNOSTICS_PERIOD_S`` of stamps (OK, WARN for a residual above half its bound, ERROR while a fault is detected,
STALE for a silent sensor).
"""

import collections
import functools
import math
from typing import NamedTuple

import numpy as np
from scipy.stats import chi2

from flyby_estimation.thrust_book import ThrustBook
from flyby_estimation.thrust_isolation import Allocator, isolate
from flyby_msgs_py.stamped import put_bounded, stamp_key
from flyby_sim.dynamics.rotation import quat_conjugate, quat_rotate

STALE_PERIODS = 5.0
FRESH_SAMPLES = 20  # a stale sensor clears once this many of its samples in a row arrived fresh (module doc)
WINDOW = 20
OUTLIER_BURST = 3
NIS_FALSE_ALARM = 1e-8  # per window; judged at every sample, about 4e-5 an hour of a 10 Hz sensor
THRUST_WINDOW = 10
THRUST_SIGMAS = 6.0
LEAK_INTERVALS = 4  # a thrust no command asked for must persist this many intervals (module doc)
STEADY_SIGMAS = 4.0  # a leak repeats within this many sigmas of two samples (module doc)
THRUST_RELATIVE = 0.05  # beyond the specified errors: the attitude estimates a burn is turned by (module doc)
ISOLATION_DEG = 25.0
CLEAR_WINDOWS = 2
DIAGNOSTICS_PERIOD_S = 1.0
THRUST_SETTLE_S = 30.0  # after a firing the navigation models, its execution error settles in the innovations
WHEEL_WINDOW = 10
WHEEL_RELATIVE = 0.05  # the motor's torque error allowed, of the commanded impulse
WHEEL_SATURATION = 0.95  # of the momentum limit
COMMANDS_KEPT = 4 * WHEEL_WINDOW  # the wheel commands kept (one per IMU sample, the window's and a margin)
LEVEL_OK = 'OK'
LEVEL_WARN = 'WARN'
LEVEL_ERROR = 'ERROR'
LEVEL_STALE = 'STALE'


class MonitorStatus(NamedTuple):
    """One monitor's status (diagnostic_msgs/DiagnosticStatus): name, level, message, values (text)."""

    name: str
    level: str
    message: str
    values: dict


class Diagnostics(NamedTuple):
    """The monitors' statuses at stamp t [s] (/diagnostics)."""

    t: float
    statuses: tuple


class Detection(NamedTuple):
    """A fault a monitor detected (``detected`` True) or cleared: its kind, component and figures."""

    t: float
    monitor: str
    kind: str
    component: str
    detected: bool
    message: str
    values: dict


@functools.cache
def _nis_bound(dof, samples):
    """The mean NIS of ``samples`` consistent samples of ``dof`` exceeds this with probability NIS_FALSE_ALARM (the
    chi-square quantile over samples; the same few at every stamp, so kept)."""
    return chi2.ppf(1.0 - NIS_FALSE_ALARM, dof * samples) / samples


class SensorMonitor:
    """Staleness and innovations of one sensor (module doc)."""

    def __init__(self, name, rate_hz, dof=3, innovations=True):
        self.name = name
        self.period_s = 1.0 / rate_hz
        self.dof = dof
        self.innovations = innovations
        self.t_now = -math.inf  # the receiver's time: the latest stamp judged [s]
        self.t_arrival = None  # the receiver's time the last sample arrived at [s]
        self.ages = collections.deque(maxlen=FRESH_SAMPLES)  # the last samples' ages at their arrival [s]
        self.t_first_input = None
        self.window = collections.deque(maxlen=WINDOW)  # (rejected, nis)
        monitor = f'sensor/{name}'
        self.latches = {'sensor_stale': _Latch(monitor, 1, name),
                        'sensor_outliers': _Latch(monitor, CLEAR_WINDOWS * WINDOW, name),
                        'sensor_inconsistent': _Latch(monitor, CLEAR_WINDOWS * WINDOW, name)}
        self.fresh = False  # a sample since the last judgement

    def on_sample(self, t, rejected=False, nis=math.nan, transient=False):
        """A sample at t: rejected by the filter's gate, or its NIS; transient: the filter settles a firing's
        execution error (the innovation rules skip it)."""
        self.t_arrival = max(self.t_now, t)
        self.ages.append(self.t_arrival - t)
        if self.innovations and not transient and (rejected or math.isfinite(nis)):
            self.window.append((rejected, nis))
            self.fresh = True

    def judge(self, t, explained=False):
        """Detections (and clearings) at stamp t; the status. explained: a detected thrust fault explains the
        innovations (the filter does not know the thrust): the innovation rules wait."""
        self.t_now = max(self.t_now, t)
        if self.t_first_input is None:
            self.t_first_input = t
        silent_s = self.t_now - (self.t_arrival if self.t_arrival is not None else self.t_first_input)
        bound_s = STALE_PERIODS * self.period_s + 1e-9
        age_s = max(self.ages, default=0.0)  # the oldest of the last FRESH_SAMPLES at its arrival
        stale = silent_s > bound_s or age_s > bound_s
        out = self._set('sensor_stale', stale, t, f'{self.name}: no sample for {silent_s:.2f} s' if silent_s > bound_s
                        else f'{self.name}: a sample arrived {age_s:.2f} s after its stamp',
                        dict(silent_s=silent_s, age_s=age_s))
        rejected = sum(1 for r, _ in self.window if r)
        nis = [x for r, x in self.window if not r]
        full = len(self.window) == WINDOW
        mean_nis = float(np.mean(nis)) if full and len(nis) >= WINDOW // 2 else math.nan
        nis_bound = _nis_bound(self.dof, len(nis)) if nis else math.inf
        if self.fresh and not explained:  # the innovation rules at each new sample
            self.fresh = False
            out += self._set('sensor_outliers', full and rejected >= OUTLIER_BURST, t,
                             f'{self.name}: {rejected} of its last {WINDOW} samples rejected',
                             dict(rejected=rejected))
            out += self._set('sensor_inconsistent', mean_nis > nis_bound, t,
                             f'{self.name}: mean NIS {mean_nis:.3g} over its last {len(nis)} accepted samples above '
                             f'{nis_bound:.3g}', dict(mean_nis=mean_nis, bound=nis_bound))
        active = sorted(kind for kind, latch in self.latches.items() if latch.active)
        level = LEVEL_STALE if stale else LEVEL_ERROR if active else (
            LEVEL_WARN if rejected or mean_nis > 0.5 * (nis_bound + self.dof) else LEVEL_OK)
        values = dict(silent_s=silent_s, age_s=age_s, rejected=rejected, mean_nis=mean_nis, nis_bound=nis_bound)
        return out, MonitorStatus(f'sensor/{self.name}', level, ', '.join(active) or 'nominal', values)

    def _set(self, kind, condition, t, message, values):
        """The latch of ``kind``: a detection where the condition starts to hold, a clearing after it."""
        return self.latches[kind].update(t, condition, lambda: (kind, self.name, message, values))


class _Latch:
    """A monitor's detection, held from the judgement its rule starts to hold at until ``clear_after`` judgements
    within its bound."""

    def __init__(self, monitor, clear_after, component=None):
        """component: what a clearing names (the monitor's own name by default)."""
        self.monitor, self.clear_after = monitor, clear_after
        self.component = monitor if component is None else component
        self.active = None  # (kind, t) of the detection
        self.nominal = 0

    @property
    def kind(self):
        """The kind detected, or None."""
        return None if self.active is None else self.active[0]

    def update(self, t, beyond, describe):
        """Detections at stamp t: where the rule holds (beyond) and nothing is detected, ``describe()`` gives
        (kind, component, message, values); a clearing once it has not held for clear_after judgements."""
        if beyond:
            self.nominal = 0
            if self.active is not None:
                return []
            kind, component, message, values = describe()
            self.active = (kind, t)
            return [Detection(t, self.monitor, kind, component, True, message, values)]
        if self.active is None:
            return []
        self.nominal += 1
        if self.nominal < self.clear_after:
            return []
        kind, _ = self.active
        self.active = None
        return [Detection(t, self.monitor, kind, self.component, False, f'{self.component}: {kind} cleared', {})]


class _Interval(NamedTuple):
    """One IMU interval as the thrust monitor judges it: the residual specific force [m/s^2, chaser_body], its
    allowance for the thrusters' errors and the minimum impulse bit [m/s^2], the thrust expected [m/s^2], its
    burns' edges (``ThrustBook.on_interval``), and for the isolation the residual before the allocation's shortfall
    is taken out and what the thrusters were commanded (``thrust_isolation.Commanded``, None where unknown)."""

    residual: np.ndarray
    slack: float
    expected: float
    edges: tuple
    raw: np.ndarray
    commanded: object


def _edge_allowance(before, window):
    """The window's allowance for its burns' timing [m/s^2, summed over its intervals]. A burn's start or end may
    lie off the filter's (the plant starts a command that reaches it late on its arrival): its impulse then moves
    into the neighbouring interval, which the window's mean does not see unless it crosses the window's ends. So a
    burn whose start and end both lie inside the window, in neither its first nor its last interval, needs none; the
    others' edges count their whole acceleration, as do the edges of the interval before the window."""
    marks = collections.defaultdict(list)  # seq -> (index, acceleration, starts, ends)
    for i, interval in enumerate(window):
        for seq, accel, starts, ends in interval.edges:
            marks[seq].append((i, accel, starts, ends))
    total = sum(accel for _, accel, _, _ in before.edges) if before is not None else 0.0
    for edges in marks.values():
        inside = (all(0 < i < len(window) - 1 for i, *_ in edges) and any(e[2] for e in edges)
                  and any(e[3] for e in edges))
        total += 0.0 if inside else sum(accel for _, accel, _, _ in edges)
    return total


class ThrustMonitor:
    """The thrusters' force against the accelerometer (module doc)."""

    def __init__(self, accel_sigma_mps2, relative_error, force_directions_body, layout=None):
        """The accelerometer's 1-sigma [m/s^2]; the thrusters' errors' relative 3 sigma; their force directions
        (M, 3), chaser_body; layout: the ``ThrusterLayout`` the isolation allocates the commands on (None: thrusters
        named by direction alone)."""
        self.accel_sigma_mps2 = accel_sigma_mps2
        self.relative_error = relative_error
        self.force_directions_body = np.asarray(force_directions_body, dtype=float)
        # The hypotheses allocate over every thruster: after a thrust fault is detected the supervisor may close
        # thrusters (``thrusters_isolated``, which the estimator does not hear), so from then on, by direction.
        self.allocator = None if layout is None else Allocator(layout)
        self.window = collections.deque(maxlen=THRUST_WINDOW + 1)  # the window's _Intervals and the one before it
        self.latch = _Latch('thrusters', CLEAR_WINDOWS * THRUST_WINDOW)
        self.outlier_latch = _Latch('thrusters', CLEAR_WINDOWS * THRUST_WINDOW, 'imu')  # the accelerometer's
        self.fresh = False
        self.status = MonitorStatus('thrusters', LEVEL_OK, 'waiting for a window', {})

    def on_interval(self, residual_body_mps2, expected_thrust_mps2, commanded_body_mps2=(0.0, 0.0, 0.0),
                    granularity_mps2=0.0, edges=(), commanded=None):
        """One interval's mean residual specific force [m/s^2, chaser_body], its expected total thrust acceleration
        (every firing thruster's, couples included) [m/s^2], the force commands' acceleration [m/s^2,
        chaser_body], the minimum impulse bit's granularity [m/s^2], its burns' edges and what it commanded of the
        thrusters (``ThrustBook``; None: unknown). A force command's shortfall along itself, down to nothing, is the
        allocation's (a thrust below the minimum impulse bit, a wrench beyond the thrusters: the plant reports it
        undelivered), not a fault: it is taken out of the residual the rule judges (the isolation allocates the
        command itself)."""
        raw = np.asarray(residual_body_mps2, dtype=float)
        residual = raw
        force = np.asarray(commanded_body_mps2, dtype=float)
        size = float(np.linalg.norm(force))
        if size > 0.0:
            along = float(residual @ force) / size
            if -size <= along <= 0.0:
                residual = residual - along * force / size
        slack = (self.relative_error + THRUST_RELATIVE) * float(expected_thrust_mps2) + float(granularity_mps2)
        self.window.append(_Interval(residual, slack, float(expected_thrust_mps2), tuple(edges), raw, commanded))
        self.fresh = True

    def _outliers(self, before, window):
        """The indices of the window's accelerometer outliers (module doc): an interval whose residual is more than
        its expected thrust could lack (beyond THRUST_SIGMAS of one sample's noise and its allowances, a burn's
        edge in it or next to it included: its timing moves impulse into the neighbour) is thrust no command asked
        for, which a thruster stuck on gives from its onset on, the same in every interval; one not in a run of
        LEAK_INTERVALS consecutive such intervals, each within STEADY_SIGMAS of the two samples' noise and their
        allowances of the one before, is no thruster's. Returns them and the settled ones: in a run that neither
        starts in the window's first interval (it may have begun before) nor ends in its last two (the interval
        after it has its whole allowance: its neighbour's edges are in), which no later interval changes."""
        sigma = self.accel_sigma_mps2
        edges = [sum(e[1] for e in iv.edges) for iv in ([before] if before is not None else []) + window]
        edges = ([0.0] if before is None else []) + edges + [0.0]  # [the one before, the window's, the one after]
        allowed = [iv.slack + sum(edges[i:i + 3]) for i, iv in enumerate(window)]
        excess = [float(np.linalg.norm(iv.residual)) > iv.expected + THRUST_SIGMAS * sigma + a
                  for iv, a in zip(window, allowed, strict=True)]
        runs, run = [], []
        for i, interval in enumerate(window):
            steady = run and excess[i] and float(np.linalg.norm(interval.residual - window[i - 1].residual)) <= (
                STEADY_SIGMAS * sigma * math.sqrt(2.0) + allowed[i] + allowed[i - 1])
            if run and not steady:
                runs.append(run)
                run = []
            if excess[i]:
                run.append(i)
        runs.append(run)
        short = [r for r in runs if 0 < len(r) < LEAK_INTERVALS]
        return ({i for r in short for i in r},
                {i for r in short if r[0] > 0 and r[-1] < len(window) - 2 for i in r})

    def judge(self, t):
        """Detections at a new interval's stamp t, and the status."""
        if not self.fresh or len(self.window) < THRUST_WINDOW:
            return [], self.status
        self.fresh = False
        before, window = (self.window[0], list(self.window)[1:]) if len(self.window) > THRUST_WINDOW else (
            None, list(self.window))
        outliers, settled = self._outliers(before, window)
        out = self.outlier_latch.update(t, len(settled) >= OUTLIER_BURST, lambda: (
            'sensor_outliers', 'imu', f'imu: {len(settled)} accelerometer outliers in the last {THRUST_WINDOW} '
            'intervals', dict(outliers=len(settled))))
        kept = [iv for i, iv in enumerate(window) if i not in outliers]
        if len(kept) < THRUST_WINDOW // 2:  # the accelerometer is not to be believed: neither raised nor cleared
            self.status = MonitorStatus('thrusters', LEVEL_ERROR if self.latch.active or self.outlier_latch.active
                                        else LEVEL_WARN,
                                        f'not judged: {len(outliers)} accelerometer outliers in the last '
                                        f'{THRUST_WINDOW} intervals', dict(outliers=len(outliers)))
            return out, self.status
        residual = np.mean([iv.residual for iv in kept], axis=0)
        slack = (sum(iv.slack for iv in kept) + _edge_allowance(before, window)) / len(kept)
        expected = float(np.mean([iv.expected for iv in kept]))
        noise = self.accel_sigma_mps2 / math.sqrt(len(kept))  # on the mean of the kept samples
        bound = THRUST_SIGMAS * noise + slack
        size = float(np.linalg.norm(residual))
        values = dict(residual_mps2=size, bound_mps2=bound, residual_body=residual.round(6).tolist(),
                      outliers=len(outliers))

        def describe():
            kind, candidates, how = self._isolate(residual, expected, kept)
            return (kind, f'thrusters {candidates}' if candidates else 'thrusters',
                    f'{kind}: residual {size:.3g} m/s^2 above {bound:.3g} along '
                    f'{np.round(residual / size, 3).tolist()} (chaser_body); candidates {candidates} {how[0]}',
                    dict(values, candidates=candidates, **how[1]))

        out += self.latch.update(t, size > bound, describe)
        active = [latch.kind for latch in (self.latch, self.outlier_latch) if latch.active]
        level = LEVEL_ERROR if active else LEVEL_WARN if size > 0.5 * bound or outliers else LEVEL_OK
        self.status = MonitorStatus('thrusters', level, ', '.join(active) or 'nominal', values)
        return out, self.status

    def _isolate(self, residual, expected, kept):
        """(kind, candidate thrusters, (how named, its figures)): the hypothesis per thruster that explains the kept
        intervals' residual series (``thrust_isolation``; at the run's first thrust detection only, __init__); where
        none does, by direction: a residual beyond the
        thrust expected of the firing (none where nothing is expected) is thrust no command asked for, along the
        thrusters that give it; else a shortfall, against them."""
        found = self._hypotheses(kept)
        self.allocator = None  # the first detection only (__init__)
        if found is not None:
            return found.kind, found.candidates, (
                f'by hypothesis (chi-square {found.chi2:.3g}, {found.dof} dof)',
                dict(isolation='hypothesis', chi2=round(found.chi2, 3), dof=found.dof))
        directions = self.force_directions_body
        unit = residual / np.linalg.norm(residual)
        kind = 'thrust_excess' if np.linalg.norm(residual) > expected else 'thrust_deficit'
        sign = 1.0 if kind == 'thrust_excess' else -1.0
        cosines = directions @ (sign * unit)
        return kind, [int(i) for i in np.flatnonzero(cosines > math.cos(math.radians(ISOLATION_DEG)))], (
            'by direction', dict(isolation='direction'))

    def _hypotheses(self, kept):
        """``thrust_isolation.isolate`` over the kept intervals, each residual against what the allocation delivers
        and with its variance (the accelerometer's, the specified errors of every commanded thruster at 1 sigma, a
        third of THRUST_RELATIVE of the thrust expected); None where the commands are unknown or no hypothesis
        names one kind."""
        if self.allocator is None or any(iv.commanded is None for iv in kept):
            return None
        firings = [self.allocator.firing(iv.commanded) for iv in kept]
        residuals = [iv.raw + f.undelivered for iv, f in zip(kept, firings, strict=True)]
        variances = [self.accel_sigma_mps2**2 + (self.relative_error / 3.0)**2 * float(f.mean @ f.mean)
                     + (THRUST_RELATIVE / 3.0 * iv.expected)**2 for iv, f in zip(kept, firings, strict=True)]
        mass = float(np.mean([iv.commanded.mass_kg for iv in kept]))
        return isolate(residuals, firings, variances, self.force_directions_body,
                       self.allocator.layout.max_thrust_n / mass, self.relative_error / 3.0)


class WheelMonitor:
    """Each wheel's momentum change against its commanded torque (module doc)."""

    def __init__(self, wheels, tachometer_sigma_rad_s, gyro_sigma_rad_s):
        """wheels: the ``ReactionWheels`` (axes, limits, spin inertia); the tachometers' and the gyro's 1-sigma
        [rad/s]."""
        self.axes, self.spin_inertia = wheels.axes_body, wheels.spin_inertia_kg_m2
        self.max_torque, self.max_momentum = wheels.max_torque_n_m, wheels.max_momentum_n_m_s
        self.noise = THRUST_SIGMAS * math.sqrt(2.0) * self.spin_inertia * math.hypot(tachometer_sigma_rad_s,
                                                                                     gyro_sigma_rad_s)
        self.commands = []  # (stamp, torques clipped), by stamp
        self.halves = {}  # stamp key -> the tachometers' speeds or the gyro's rate, whichever came first
        self.momenta = collections.deque(maxlen=WHEEL_WINDOW + 2)  # (t, each wheel's axial momentum)
        self.latch = _Latch('wheels', CLEAR_WINDOWS * WHEEL_WINDOW)
        self.fresh = False
        self.paused = False
        self.status = MonitorStatus('wheels', LEVEL_OK, 'waiting for a window', {})

    def pause(self, paused):
        """While the arm grasps, the wheels fly no command (the plant's grasp holds them): not judged, and judged
        again from fresh samples after it."""
        if paused and not self.paused:
            self.momenta.clear()
            self.halves.clear()
            self.status = MonitorStatus('wheels', LEVEL_OK, 'paused: the arm grasps', {})
        self.paused = paused

    def on_command(self, t_stamp, torques_n_m):
        """Guidance's motor torques [N m], held from t_stamp [s]."""
        torques = np.clip(np.asarray(torques_n_m, dtype=float), -self.max_torque, self.max_torque)
        self.commands = sorted([c for c in self.commands if c[0] != t_stamp] + [(float(t_stamp), torques)],
                               key=lambda c: c[0])[-COMMANDS_KEPT:]

    def on_sample(self, t, speeds_rad_s=None, omega_body_rad_s=None):
        """The tachometers' speeds [rad/s] or the gyro's rate [rad/s, chaser_body] at t: paired by stamp."""
        if self.paused:
            return
        key = stamp_key(t)
        other = self.halves.pop(key, None)
        if other is None:
            put_bounded(self.halves, key, (speeds_rad_s, omega_body_rad_s), 4)
            return
        speeds = np.asarray(speeds_rad_s if speeds_rad_s is not None else other[0], dtype=float)
        omega = np.asarray(omega_body_rad_s if omega_body_rad_s is not None else other[1], dtype=float)
        if speeds.shape != self.spin_inertia.shape or not (np.all(np.isfinite(speeds))
                                                           and np.all(np.isfinite(omega))):
            return
        self.momenta.append((float(t), self.spin_inertia * (speeds + self.axes @ omega)))
        self.fresh = True

    def _impulse(self, t0, t1):
        """Each wheel's commanded impulse over [t0, t1] [N m s] and its magnitude's."""
        impulse, size = np.zeros(len(self.axes)), np.zeros(len(self.axes))
        for k, (t_stamp, torques) in enumerate(self.commands):
            t_next = self.commands[k + 1][0] if k + 1 < len(self.commands) else math.inf
            overlap = min(t1, t_next) - max(t0, t_stamp)
            if overlap > 0.0:
                impulse, size = impulse + torques * overlap, size + np.abs(torques) * overlap
        return impulse, size

    def judge(self, t):
        """Detections at a new paired sample's stamp t, and the status."""
        if not self.fresh or len(self.momenta) < self.momenta.maxlen:
            return [], self.status
        self.fresh = False
        (t0, h0), (t1, h1) = self.momenta[0], self.momenta[-2]
        while len(self.commands) > 1 and self.commands[1][0] <= t0:
            self.commands.pop(0)
        if not self.commands or self.commands[0][0] > t0:  # the torque held before the first command heard is
            return [], self.status  # unknown (a monitor started late, a respawned estimator)
        expected, size = self._impulse(t0, t1)
        residual = (h1 - h0) - expected
        bound = self.noise + WHEEL_RELATIVE * size
        judged = np.maximum(np.abs(h0), np.abs(h1)) < WHEEL_SATURATION * self.max_momentum
        failing = [int(i) for i in np.flatnonzero(judged & (np.abs(residual) > bound))]
        values = dict(residual_n_m_s=np.round(residual, 6).tolist(), bound_n_m_s=np.round(bound, 6).tolist())

        def describe():
            deficit = [i for i in failing if residual[i] * expected[i] < 0.0
                       and abs(residual[i]) <= abs(expected[i]) + bound[i]]
            kind, candidates = ('wheel_torque_deficit', deficit) if deficit else ('wheel_torque_excess', failing)
            return (kind, f'wheels {candidates}',
                    f'{kind}: wheels {candidates} changed their momentum by '
                    f'{np.round(h1 - h0, 5)[candidates].tolist()} N m s over {t1 - t0:.2f} s against '
                    f'{np.round(expected, 5)[candidates].tolist()} commanded', dict(values, candidates=candidates))

        out = self.latch.update(t, bool(failing), describe)
        level = LEVEL_ERROR if self.latch.active else LEVEL_WARN if np.any(np.abs(residual) > 0.5 * bound) else LEVEL_OK
        self.status = MonitorStatus('wheels', level, self.latch.kind or 'nominal', values)
        return out, self.status


class HealthMonitor:
    """Every monitor of the chaser, their detections and their statuses (module doc)."""

    def __init__(self, params):
        """params: ``params.HealthParams``."""
        self.params = params
        self.sensors = {'relative_position': SensorMonitor('relative_position', params.position_rate_hz),
                        'target_attitude': SensorMonitor('target_attitude', params.attitude_rate_hz)}
        self.thrust = self.wheels = None
        if params.rigid_body:
            self.sensors['imu'] = SensorMonitor('imu', params.imu_rate_hz, innovations=False)
            self.sensors['star_tracker'] = SensorMonitor('star_tracker', params.star_tracker_rate_hz)
            self.sensors['tachometers'] = SensorMonitor('tachometers', params.imu_rate_hz, innovations=False)
            layout = params.thruster_layout
            relative = 3.0 * math.hypot(params.thrust_magnitude_sigma, params.thrust_misalignment_sigma_rad)
            self.thrust = ThrustMonitor(params.accel_sigma_mps2, relative, layout.force_directions_body, layout)
            levers = np.linalg.norm(np.cross(layout.positions_body_m, layout.force_directions_body), axis=1)
            self.book = ThrustBook(max(float(levers.min()), 1e-3), params.min_impulse_bit_ns * params.imu_rate_hz)
            self.wheels = WheelMonitor(params.wheels, params.tachometer_sigma_rad_s, params.gyro_sigma_rad_s)
        self.suspended = set()  # sensors no longer expected (the target's after the capture)
        self.t_diagnostics = -math.inf

    def on_sample(self, sensor, t, rejected=False, nis=math.nan, transient=False):
        """A sample of ``sensor`` at t: rejected by its filter's gate, or its NIS (nan where none); transient as
        ``SensorMonitor.on_sample``."""
        self.sensors[sensor].on_sample(t, rejected, nis, transient)

    def suspend(self, sensor):
        """The sensor is no longer judged (its filter stopped: the target's attitude after the capture)."""
        self.suspended.add(sensor)

    def on_interval(self, burns, t0, t1, q_hill_from_body, specific_force_body, mass_kg):
        """An IMU interval [t0, t1] [s]: the accelerometer's mean specific force [m/s^2, chaser_body] at the attitude
        estimate, the navigation filter's burns now and the chaser's mass [kg]: the previous interval judged by
        the ``ThrustMonitor``."""
        if self.thrust is None:
            return
        self.book.on_burns(burns)
        q = np.asarray(q_hill_from_body, dtype=float)
        dv_hill = quat_rotate(q, np.asarray(specific_force_body, dtype=float)) * (t1 - t0)
        judged = self.book.on_interval(t0, t1, dv_hill, quat_conjugate(q), mass_kg)
        if judged is not None:
            self.thrust.on_interval(*judged)

    def suspend_thrust(self):
        """No longer judged: after the capture the accelerometer sees the combined body turn and the arm push."""
        self.thrust = None

    def judge(self, t):
        """(detections, Diagnostics or None) at stamp t: every monitor judged, the statuses every
        DIAGNOSTICS_PERIOD_S."""
        detections, statuses = [], []
        if self.thrust is not None:
            found, status = self.thrust.judge(t)
            detections += found
            statuses.append(status)
        if self.wheels is not None:
            found, status = self.wheels.judge(t)
            detections += found
            statuses.append(status)
        thrust_fault = self.thrust is not None and self.thrust.latch.active is not None
        for name, monitor in self.sensors.items():
            if name in self.suspended:
                continue
            found, status = monitor.judge(t, explained=thrust_fault and name == 'relative_position')
            detections += found
            statuses.append(status)
        diagnostics = None
        if t >= self.t_diagnostics + DIAGNOSTICS_PERIOD_S - 1e-9:
            self.t_diagnostics = t
            diagnostics = Diagnostics(t, tuple(statuses))
        return detections, diagnostics
