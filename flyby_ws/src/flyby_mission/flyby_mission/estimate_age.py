"""The age of the estimates the supervisor flies and decides on (docs/faults.md): a lost or late estimate stream found
where the estimates are consumed.

Guidance, the planner and the supervisor act on the last estimate they got, and a topic fault (flyby_msgs_py.
link_faults) may lose or delay an estimate stream on its way without the estimator knowing. The estimator publishes
the target's estimate at each target attitude sample its filter accepts and the chaser's at each relative position
(point-mass chaser: its update, or its prediction at an outlier) or at each IMU sample (rigid body): one period of
that sensor, 0.1 s at paper_flyby's 10 Hz.
The rule, per stream, mirrors the sensors' staleness (flyby_estimation.health):

* **Time**: the receiver's, the supervisor's clock held back to the estimator's own progress (its heartbeat, the last
  sim time it reports handled). The estimator publishes an estimate before the progress report of its stamp, so by
  that time an estimate is never late for the pace; in the graph the clock alone leads the estimator by up to two
  flow-control periods (2 s in the launcher), which a bound of a few periods would take for a lost stream. Headless
  both are the plant's time. Judged at the supervisor's clock and at each estimate's arrival, on stamps only.
* **Stale** (``estimate_stale``, naming ``target_estimate`` or ``chaser_estimate``): no estimate for ``STALE_PERIODS``
  of the stream's periods, or one arrived older than that (a late estimate is no proof the stream is fresh); cleared
  once its last ``health.FRESH_SAMPLES`` estimates arrived fresh (at a loss's first estimate after it, a delay
  FRESH_SAMPLES periods after its estimates come fresh again).
* **Bound**: ``STALE_PERIODS`` = the sensors' ``health.STALE_PERIODS``, one period more (the estimator judges a sensor
  at its next input) and ``health.OUTLIER_BURST`` - 1 more (that many rejected samples, fewer than an outlier burst,
  may end the accepted ones before a sensor's gap): 8 periods, 0.8 s at 10 Hz. So a gap of the estimates that a gap of
  their sensor explains is found by the estimator's own monitor first, and this one leaves it to it (below).
* **Judged** while the estimator is expected to publish the stream: in the phases that fly and decide on it
  (supervisor.ACTIVE_PHASES: not after the capture, where the estimator stops the target's filter, nor after an abort
  or an escape), from the stream's first estimate; not while the estimator holds a ``sensor_stale`` or
  ``sensor_outliers`` on the stream's sensor (the estimator found that gap and the fault table answered it: the
  estimates stop with its accepted samples); not while the watchdog finds the estimator lost, and after that from the
  stream's first estimate again (a silent estimator is the watchdog's ``node_lost``, never also stale here; a respawned
  one publishes once its filters start). A crashed estimator's heartbeat stops with its estimates, so the time held
  back to it stops too: it is the watchdog's alone; one whose core raised (fenced off, its node still reporting
  progress) is seen here, as its streams' staleness. A finding is stamped at that time, the graph's as the headless
  driver's.

No ROS here.
"""

import collections
from typing import NamedTuple

from flyby_estimation import health
from flyby_msgs_py import contract as c
from flyby_msgs_py import params
from flyby_msgs_py.link_faults import COMPONENT_OF_TOPIC

STALE_PERIODS = health.STALE_PERIODS + 1 + (health.OUTLIER_BURST - 1)  # 8 (module doc)
MONITOR = 'estimate_age'
KIND = 'estimate_stale'
TARGET_ESTIMATE = COMPONENT_OF_TOPIC[c.EST_TARGET_ODOM]  # the components, as the summary matches them to topic faults
CHASER_ESTIMATE = COMPONENT_OF_TOPIC[c.EST_CHASER_ODOM]
# The estimator's detections on a stream's sensor that stop its estimates (module doc).
EXPLAINING_KINDS = ('sensor_stale', 'sensor_outliers')


def _period_s(rate_hz):
    return 1.0 / rate_hz


def _is_rigid_body(scenario):
    return scenario.chaser.model == 'rigid_body'


@params.record
class EstimateAgeParams:
    """What the estimate-age monitor reads of the scenario: the periods [s] of the sensors the estimator publishes its
    estimates at (module doc) and whether the chaser is a rigid body (its estimate at the IMU's samples)."""

    target_attitude_period_s: float = params.key('sensors.target_attitude.rate_hz', _period_s)
    relative_position_period_s: float = params.key('sensors.relative_position.rate_hz', _period_s)
    imu_period_s: float = params.key('sensors.chaser_imu.rate_hz', _period_s)
    rigid_body: bool = params.derived(_is_rigid_body)


class Finding(NamedTuple):
    """A stream found stale (``detected``) or fresh again at t [s], the receiver's time (the supervisor's clock held
    back to the estimator's progress), with the rule's figures [s]."""

    t: float
    component: str
    detected: bool
    message: str
    values: dict


class _Stream:
    """One estimate stream's arrivals (module doc): its sensor and period [s], its latest stamp [s] (None: waiting for
    its first estimate) and the ages [s] its last FRESH_SAMPLES estimates arrived at."""

    def __init__(self, component, sensor, period_s):
        self.component, self.sensor = component, sensor
        self.bound_s = STALE_PERIODS * period_s + 1e-9
        self.t_latest = None
        self.ages = collections.deque(maxlen=health.FRESH_SAMPLES)
        self.stale = False

    def restart(self):
        """Waiting for the first estimate again (the detection held until fresh estimates clear it)."""
        self.t_latest = None
        self.ages.clear()


class EstimateAgeMonitor:
    """The target's and the chaser's estimate streams judged by their age (module doc). The supervisor feeds it the
    estimates' stamps, the estimator's progress and its sensor detections, the clock, the phase and the watchdog's
    verdict on the estimator; each judgement returns the Findings to publish."""

    def __init__(self, p: EstimateAgeParams):
        chaser = ('imu', p.imu_period_s) if p.rigid_body else ('relative_position', p.relative_position_period_s)
        self.streams = {TARGET_ESTIMATE: _Stream(TARGET_ESTIMATE, 'target_attitude', p.target_attitude_period_s),
                        CHASER_ESTIMATE: _Stream(CHASER_ESTIMATE, *chaser)}
        self.t_estimator = None  # the estimator's latest progress [s] (its heartbeat)
        self.explained = set()  # the estimator's sensors holding a detection that stops their estimates

    def on_progress(self, t):
        """The estimator's heartbeat: the sim time t [s] it reports handled."""
        self.t_estimator = t if self.t_estimator is None else max(self.t_estimator, t)

    def on_detection(self, kind, component, detected):
        """A health monitor's fault_detected (detected) or fault_recovered of ``kind`` on ``component``."""
        if kind in EXPLAINING_KINDS:
            (self.explained.add if detected else self.explained.discard)(component)

    def _now(self, t_clock):
        """The receiver's time [s]: the clock held back to the estimator's progress; None before its first report."""
        return None if self.t_estimator is None else min(t_clock, self.t_estimator)

    def on_estimate(self, component, t_stamp, t_clock, judged):
        """An estimate of the stream ``component`` stamped t_stamp [s] admitted at the supervisor's clock t_clock [s];
        judged: the phase flies on it and the watchdog has the estimator (module doc)."""
        stream = self.streams[component]
        now = self._now(t_clock)
        stream.ages.append(0.0 if now is None else max(0.0, now - t_stamp))
        stream.t_latest = t_stamp if stream.t_latest is None else max(stream.t_latest, t_stamp)
        return self._judge(stream, t_clock) if judged else []

    def judge(self, t_clock, judged, estimator_lost):
        """Every stream judged at the supervisor's clock t_clock [s] (judged as ``on_estimate``); a lost estimator's
        streams wait for their first estimate again."""
        if estimator_lost:  # a respawned estimator never clears its predecessor's detections
            for stream in self.streams.values():
                stream.restart()
            self.explained.clear()
            return []
        return [f for stream in self.streams.values() for f in self._judge(stream, t_clock)] if judged else []

    def _judge(self, stream, t_clock):
        now = self._now(t_clock)
        if now is None or stream.t_latest is None:
            return []
        silent_s = now - stream.t_latest
        age_s = max(stream.ages, default=0.0)
        stale = silent_s > stream.bound_s or age_s > stream.bound_s
        if stale == stream.stale or (stale and stream.sensor in self.explained):
            return []
        stream.stale = stale
        values = dict(silent_s=silent_s, age_s=age_s, bound_s=stream.bound_s)
        if not stale:
            return [Finding(now, stream.component, False, f'{stream.component}: {KIND} cleared', values)]
        why = (f'no estimate for {silent_s:.2f} s' if silent_s > stream.bound_s else
               f'an estimate arrived {age_s:.2f} s after its stamp')
        return [Finding(now, stream.component, True, f'{stream.component}: {why} (bound {stream.bound_s:.2f} s)',
                        values)]
