"""Faults injected into the plant: the scenario's ``faults:`` list, its checks and its schedule (docs/faults.md).

A fault acts on the hardware the truth simulates, the same in the headless loop and the graph (both step one
``plant.Plant``), from a start time, or a delay after a phase begins, for a duration (none: permanent):

* a thruster (``index`` in the layout): ``thruster_off`` (no thrust), ``thruster_stuck_on`` (a leak: at least
  ``value`` of its maximum thrust whatever is commanded), ``thruster_degraded`` (``value`` of the commanded thrust),
  ``thruster_misaligned`` (its force direction turned by ``value`` deg about ``axis``, or an axis across it drawn
  from the seed);
* a reaction wheel (``index``): ``wheel_failed`` (no motor torque), ``wheel_torque_limited`` (``value`` of its torque
  limit, the command clipped to it);
* a sensor (``sensor``): ``sensor_dropout`` (no sample; ``imu`` is the gyro and the accelerometer, sampled together,
  ``star_tracker`` the IMU's attitude), ``sensor_outliers`` (each sample off by ``value`` times the sensor's 1-sigma
  in a direction drawn from the seed), ``gyro_bias_jump`` (the gyro's bias steps by ``value`` rad/s along ``axis``
  or a direction drawn from the seed);
* a node of the graph (``node``): ``node_crash`` (the process killed at the start and started again by the launcher,
  a respawn, at the end; none: it stays down). The plant only reports it: the drivers act on its events (the
  headless loop stops feeding the node's core and builds a fresh one, the launcher kills and restarts the process);
* a topic's link (``topic``, one of ``flyby_msgs_py.link_faults.TOPICS``): ``topic_delay`` (its messages stamped in
  the window reach their subscribers ``value`` s after their stamp), ``topic_loss`` (they never reach them). The plant
  only reports it: each receiving node's link acts on its events (``flyby_msgs_py.link_faults``, the same rule in
  both drivers); the publisher, and so the bag, are untouched.

Nothing here tells the flight software: the plant reports each fault's start and end on ``mission/events``
(``fault_injected``, ``fault_ended``) for the record and the summary, and the monitors see only its effects.
Every draw comes from the fault stream of the scenario's seed, one child per fault, so a fault added to the list
leaves the others' draws and every other stream unchanged.
"""

import dataclasses
import math

import numpy as np

from flyby_msgs_py import admission, events, link_faults
from flyby_msgs_py import contract as c
from flyby_msgs_py.event_payloads import decode_values
from flyby_msgs_py.schema import Invalid

THRUSTER_KINDS = ('thruster_off', 'thruster_stuck_on', 'thruster_degraded', 'thruster_misaligned')
WHEEL_KINDS = ('wheel_failed', 'wheel_torque_limited')
SENSOR_KINDS = ('sensor_dropout', 'sensor_outliers', 'gyro_bias_jump')
NODE_KINDS = ('node_crash',)
LINK_KINDS = link_faults.KINDS
KINDS = THRUSTER_KINDS + WHEEL_KINDS + SENSOR_KINDS + NODE_KINDS + LINK_KINDS
TOPICS = link_faults.TOPICS
# The topics of a link fault the six-degree-of-freedom chaser has alone, and the one it may not target: each of its
# chaser estimates leads to the attitude command the simulator holds its time for (flyby_sim.sim_node).
RIGID_TOPICS = (c.SENSOR_CHASER_WHEELS,)
POINT_MASS_TOPICS = (c.EST_CHASER_ODOM,)
# The nodes a node_crash may kill (the scenario's name -> the node's): the supervisor and the simulator hold the
# mission itself and are not among them.
NODES = {'estimator': 'flyby_estimator', 'planner': 'flyby_planner', 'guidance': 'flyby_guidance',
         'cam_monitor': 'flyby_cam_monitor'}
SENSORS = ('relative_position', 'target_attitude', 'star_tracker', 'imu')
RIGID_SENSORS = ('star_tracker', 'imu')  # the six-degree-of-freedom chaser's own
# value when omitted, and the interval it must lie in (lo, hi, lo closed, hi closed), by kind; None: no value
VALUES = {
    'thruster_stuck_on': (0.1, (0.0, 1.0, False, True)),  # share of the maximum thrust leaking
    'thruster_degraded': (0.5, (0.0, 1.0, True, False)),  # share of the commanded thrust given
    'thruster_misaligned': (5.0, (0.0, 90.0, False, True)),  # deg
    'wheel_torque_limited': (0.1, (0.0, 1.0, True, False)),  # share of the torque limit left
    'sensor_outliers': (20.0, (0.0, 1e6, False, True)),  # the sensor's 1-sigma
    'gyro_bias_jump': (1e-3, (0.0, 1.0, False, True)),  # rad/s
    # s; a message older than admission.MAX_AGE_S is refused by its receiver: a longer delay is a topic_loss
    'topic_delay': (1.0, (0.0, admission.MAX_AGE_S, False, True)),
}
DEFAULT_THRUSTERS = 12  # the default layout's (actuators.default_thruster_layout)
PHASES = (c.PHASE_ESTIMATION, c.PHASE_PLANNING, c.PHASE_TERMINAL_APPROACH, c.PHASE_TRAJECTORY_ADJUST, c.PHASE_FLYBY,
          c.PHASE_OPTIMAL_APPROACH, c.PHASE_SYNC_APPROACH, c.PHASE_ATTITUDE_SYNC, c.PHASE_ORBITING, c.PHASE_DOCKING,
          c.PHASE_CAPTURE, c.PHASE_ESCAPE, c.PHASE_GRASP, c.PHASE_DAMPING, c.PHASE_MASS_ESTIMATION,
          c.PHASE_TRANSPORT)


@dataclasses.dataclass(frozen=True)
class FaultSpec:
    """One fault of the scenario's list (module doc): what, where, when and how much."""

    kind: str
    index: int | None = None  # the thruster's or the wheel's
    sensor: str | None = None
    start_s: float | None = None  # sim time [s], or ...
    start_phase: str | None = None  # ... the phase whose start, plus delay_s, starts it
    delay_s: float = 0.0
    duration_s: float | None = None  # None: permanent
    value: float | None = None  # by kind (module doc); None: VALUES' default
    axis: tuple | None = None  # misalignment's or bias jump's axis, chaser_body; None: drawn from the seed
    node: str | None = None  # a node_crash's (NODES' key)
    topic: str | None = None  # a link fault's (TOPICS)

    @property
    def target(self):
        """What it acts on, as text: 'thruster 3', 'wheel 1', 'imu'."""
        if self.kind in THRUSTER_KINDS:
            return f'thruster {self.index}'
        if self.kind in WHEEL_KINDS:
            return f'wheel {self.index}'
        if self.kind in NODE_KINDS:
            return f'node {NODES[self.node]}'
        if self.kind in LINK_KINDS:
            return link_faults.fault_target(self.topic)
        return 'imu' if self.kind == 'gyro_bias_jump' else self.sensor

    @property
    def magnitude(self):
        """The value it acts with (its default where the scenario gives none), or None for a kind without one."""
        if self.kind not in VALUES:
            return None
        return VALUES[self.kind][0] if self.value is None else float(self.value)


def fault_specs(items):
    """The FaultSpecs of the scenario's validated ``faults`` list (its item views), in its order."""
    return tuple(FaultSpec(kind=x.type, index=x.index, sensor=x.sensor, start_s=x.start_s, start_phase=x.start_phase,
                           delay_s=x.delay_s, duration_s=x.duration_s, value=x.value,
                           axis=None if x.axis is None else tuple(x.axis), node=x.node, topic=x.topic)
                 for x in items)


def node_crash_event(name, values):
    """(node, down) of a node_crash's ``fault_injected`` (down True: kill it) or ``fault_ended`` (respawn it), from
    the event's name and wire values; None for any other event. What both drivers act on."""
    if name not in (events.FAULT_INJECTED, events.FAULT_ENDED) or values.get('kind') not in NODE_KINDS:
        return None
    return decode_values(name, values).target.split(' ', 1)[1], name == events.FAULT_INJECTED


def check_faults(d):
    """Checks of the resolved scenario dict's ``faults`` across keys (schema ranges hold already); raise Invalid."""
    rigid = d['chaser']['model'] == 'rigid_body'
    layout = d['chaser']['thrusters']['layout']
    n_thrusters = DEFAULT_THRUSTERS if layout is None else len(layout)
    n_wheels = len(d['chaser']['wheels']['axes'])
    imu = d['sensors']['chaser_imu']
    sigmas = {'relative_position': d['sensors']['relative_position']['noise_sigma_m'],
              'target_attitude': d['sensors']['target_attitude']['noise_sigma_deg'],
              'star_tracker': imu['star_tracker_sigma_deg'],
              'imu': max(imu['gyro_noise_sigma_rad_s'], imu['accel_noise_sigma_mps2'])}
    for i, f in enumerate(d.get('faults') or ()):
        key = f'faults[{i}]'
        kind = f['type']
        if (f['start_s'] is None) == (f['start_phase'] is None):
            raise Invalid(key, 'give exactly one of start_s and start_phase (when the fault begins)')
        if f['start_s'] is not None and f['delay_s']:
            raise Invalid(f'{key}.delay_s', 'is the delay after start_phase; with start_s give the time itself')
        hardware = kind in THRUSTER_KINDS + WHEEL_KINDS
        if hardware or kind == 'gyro_bias_jump' or f['sensor'] in RIGID_SENSORS:
            if not rigid:
                raise Invalid(f'{key}.type', f'{kind}{" of " + f["sensor"] if f["sensor"] else ""} needs chaser.model '
                                             f'rigid_body (the point mass has no thrusters, wheels or IMU)')
        count = n_thrusters if kind in THRUSTER_KINDS else n_wheels
        if hardware and (f['index'] is None or not 0 <= f['index'] < count):
            what = 'thruster of chaser.thrusters.layout' if kind in THRUSTER_KINDS else 'wheel of chaser.wheels.axes'
            raise Invalid(f'{key}.index', f'must name a {what} (0 to {count - 1}) for {kind}, got {f["index"]!r}')
        if not hardware and f['index'] is not None:
            raise Invalid(f'{key}.index', f'is for thruster and wheel faults, not {kind}')
        if kind in ('sensor_dropout', 'sensor_outliers') and f['sensor'] is None:
            raise Invalid(f'{key}.sensor', f'is required for {kind}: one of {", ".join(SENSORS)}')
        if kind not in ('sensor_dropout', 'sensor_outliers') and f['sensor'] is not None:
            raise Invalid(f'{key}.sensor', f'is for sensor_dropout and sensor_outliers, not {kind}')
        _check_value(key, kind, f['value'])
        if kind == 'sensor_outliers' and f['sensor'] in sigmas and sigmas[f['sensor']] == 0.0:
            value = VALUES[kind][0] if f['value'] is None else f['value']
            raise Invalid(f'{key}.sensor', f'{f["sensor"]} has no noise (its sigma is 0): an outlier of '
                                           f'{value:g} sigma would be none')
        if f['axis'] is not None and kind not in ('thruster_misaligned', 'gyro_bias_jump'):
            raise Invalid(f'{key}.axis', f'is for thruster_misaligned and gyro_bias_jump, not {kind}')
        if (kind in NODE_KINDS) != (f['node'] is not None):
            raise Invalid(f'{key}.node', f'is required for node_crash: one of {", ".join(NODES)}' if kind in NODE_KINDS
                          else f'is for node_crash, not {kind}')
        if f['axis'] is not None and not math.hypot(*f['axis']) > 0.0:
            raise Invalid(f'{key}.axis', f'must be nonzero, got {list(f["axis"])}')
        _check_topic(key, kind, f['topic'], rigid)


def _check_topic(key, kind, topic, rigid):
    """A link fault names one of TOPICS that this chaser's graph carries; no other fault names a topic."""
    if kind not in LINK_KINDS:
        if topic is not None:
            raise Invalid(f'{key}.topic', f'is for topic_delay and topic_loss, not {kind}')
        return
    if topic is None:
        raise Invalid(f'{key}.topic', f'is required for {kind}: one of {", ".join(TOPICS)}')
    if topic in RIGID_TOPICS and not rigid:
        raise Invalid(f'{key}.topic', f'{topic} needs chaser.model rigid_body (the point mass has no wheels)')
    if topic in POINT_MASS_TOPICS and rigid:
        raise Invalid(f'{key}.topic', f'{topic} of the rigid_body chaser leads to the attitude commands the '
                                      f'simulator holds its time for: lost or late, they would stop the graph')


def _check_value(key, kind, value):
    if kind not in VALUES:
        if value is not None:
            raise Invalid(f'{key}.value', f'{kind} takes no value')
        return
    if value is None:
        return
    lo, hi, lo_closed, hi_closed = VALUES[kind][1]
    if not ((value >= lo if lo_closed else value > lo) and (value <= hi if hi_closed else value < hi)):
        interval = f'{"[" if lo_closed else "("}{lo:g}, {hi:g}{"]" if hi_closed else ")"}'
        raise Invalid(f'{key}.value', f'must be within {interval} for {kind}, got {value!r}')


def _unit_across(rng, direction):
    """A unit vector across ``direction`` drawn from rng (uniform about it)."""
    d = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    helper = np.eye(3)[int(np.argmin(np.abs(d)))]
    e1 = np.cross(d, helper)
    e1 /= np.linalg.norm(e1)
    angle = rng.uniform(0.0, 2.0 * math.pi)
    return math.cos(angle) * e1 + math.sin(angle) * np.cross(d, e1)


def random_unit(rng):
    """A unit vector drawn uniformly on the sphere from rng."""
    v = rng.standard_normal(3)
    return v / np.linalg.norm(v)


class FaultSchedule:
    """The scenario's faults in time: which start and end at a step (``due``), and what is active now."""

    def __init__(self, specs, rng):
        """specs: FaultSpecs; rng: numpy Generator of the fault stream (one child spawned per fault)."""
        self.specs = tuple(specs)
        self._rngs = rng.spawn(len(self.specs)) if self.specs else []
        self._phase_start = {}
        self._started = [None] * len(self.specs)  # the start time of each, once begun
        self.active = []  # indices of the faults acting now, in their start order

    def rng(self, i):
        """Fault i's own Generator (its axis, its outliers' directions)."""
        return self._rngs[i]

    def axis(self, i, across=None):
        """Fault i's axis, unit: the scenario's, or drawn (across ``across`` where given) at its start."""
        spec = self.specs[i]
        if spec.axis is not None:
            a = np.asarray(spec.axis, dtype=float)
            return a / np.linalg.norm(a)
        return _unit_across(self._rngs[i], across) if across is not None else random_unit(self._rngs[i])

    def on_phase(self, phase, t):
        """The phase began at t [s] (its first start counts)."""
        self._phase_start.setdefault(phase, float(t))

    def start_time(self, i):
        """Fault i's start [s], or None while its phase has not begun."""
        spec = self.specs[i]
        if spec.start_s is not None:
            return spec.start_s
        t_phase = self._phase_start.get(spec.start_phase)
        return None if t_phase is None else t_phase + spec.delay_s

    def due(self, t):
        """(started, ended): indices of the faults that begin and that end at t [s] (from the step at t on),
        updating ``active``."""
        ended = [i for i in self.active if self.specs[i].duration_s is not None
                 and t >= self._started[i] + self.specs[i].duration_s - 1e-9]
        for i in ended:
            self.active.remove(i)
        started = []
        for i in range(len(self.specs)):
            t_start = self.start_time(i)
            if self._started[i] is None and t_start is not None and t >= t_start - 1e-9:
                self._started[i] = float(t)
                started.append(i)
                if self.specs[i].duration_s != 0.0:
                    self.active.append(i)
        return started, ended

    def sensor_fault(self, kind, sensor):
        """The index of an active fault of ``kind`` on ``sensor``, or None."""
        for i in self.active:
            if self.specs[i].kind == kind and self.specs[i].sensor == sensor:
                return i
        return None
