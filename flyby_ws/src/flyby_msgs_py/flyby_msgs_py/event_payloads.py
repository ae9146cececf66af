"""The payloads of the events whose values another core reads back, declared once (DESIGN §11).

An event's values travel as text (``wire.value_text``: floats by repr, bools 'true'/'false', sequences as JSON
lists), so every reader used to parse them on its own. Here each such event has one frozen record whose fields
are typed (float, int, str, bool, a vector as a tuple, Optional where the key may be absent), keyed by the event
name (``PAYLOADS``). ``encode`` gives the values dict the emitter passes (the same keys and values, so the wire
text is the same), the record's fields first, in their order, then the keys it does not model (figures for
humans) untouched; ``decode`` turns an event's values, as text or as numbers, back into the record.
"""

import dataclasses
import functools
import json
import types
import typing
from typing import ClassVar

import numpy as np

from flyby_msgs_py import events

Vector = tuple  # a sequence of numbers (a 3-vector, a quaternion): a JSON list on the wire


def _key(name):
    """A field whose key on the wire is not its Python name (``from`` is a keyword)."""
    return dataclasses.field(metadata={'key': name})


def _vector(v):
    """A sequence as a tuple of plain numbers, as ``wire.value_text`` writes it (numpy scalars as float)."""
    if isinstance(v, np.ndarray):
        v = v.tolist()
    return tuple(float(x) if isinstance(x, (np.floating, np.integer)) else x for x in v)


def _scalar(v):
    """A numpy scalar as the plain number or bool it stands for; anything else as it is."""
    if isinstance(v, np.bool_):
        return bool(v)
    if isinstance(v, np.floating):
        return float(v)
    if isinstance(v, np.integer):
        return int(v)
    return v


class _Payload:
    """Vectors kept as tuples and numpy scalars as plain ones: records compare by value, and encode to the text
    the emitter's own values have."""

    NAME: ClassVar[str] = ''

    def __post_init__(self):
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if v is not None:
                object.__setattr__(self, f.name, _vector(v) if _kind(type(self), f.name) is Vector else _scalar(v))


def payload(name):
    """A frozen payload record for the event ``name`` (a constant of flyby_msgs_py.events)."""
    def wrap(cls):
        cls.NAME = name
        return dataclasses.dataclass(frozen=True)(cls)
    return wrap


@payload(events.PHASE_CHANGED)
class PhaseChanged(_Payload):
    """The supervisor's transition (the transition's own values follow as extra keys)."""

    from_phase: str = _key('from')
    to_phase: str = _key('to')


@payload(events.PLAN_SELECTED)
class PlanSelected(_Payload):
    """The plan the planner selected: a fly-by (no method), 'optimal' or 'sync'; exact times [s] and offset [m]."""

    request: str | None = None
    plan: str | None = None
    method: str | None = None
    t_arrival_s: float | None = None
    t_grasp_s: float | None = None
    t_i_s: float | None = None
    t_start_s: float | None = None
    offset_m: float | None = None


@payload(events.PLAN_REFUSED)
class PlanRefused(_Payload):
    """No safe plan (the reason is the event's message)."""

    request: str | None = None
    plan: str | None = None
    planning_time_s: float | None = None


@payload(events.TARGET_REFINED)
class TargetRefined(_Payload):
    """Guidance's re-solved grasp (hill frame) and its fly-by target point, or only the kept aim's passage gap."""

    t_grasp_s: float | None = None
    shift_m: float | None = None
    x_g_hill_m: Vector | None = None
    v_g_hill_mps: Vector | None = None
    x_ft_hill_m: Vector | None = None
    v_ft_hill_mps: Vector | None = None
    q_hill_from_body: Vector | None = None
    omega_body_rad_s: Vector | None = None
    passage_gap_m: float | None = None


@payload(events.STATION_REACHED)
class StationReached(_Payload):
    """The synchronized approach reached its station at t_arrival_s [s]."""

    t_arrival_s: float | None = None


@payload(events.ATTITUDE_SYNCHRONIZED)
class AttitudeSynchronized(_Payload):
    """The relative attitude held within tolerance [deg, deg/s]; the docking's start and grasp times [s]."""

    attitude_error_deg: float | None = None
    rate_error_deg_s: float | None = None
    attitude_tolerance_deg: float | None = None
    rate_tolerance_deg_s: float | None = None
    rotation_period_s: float | None = None
    t_docking_s: float | None = None
    t_grasp_s: float | None = None


@payload(events.DOCKING_STARTED)
class DockingStarted(_Payload):
    """The docking from the station: its start and grasp times [s], the final range from the port [m]."""

    t_docking_s: float | None = None
    t_grasp_s: float | None = None
    offset_m: float | None = None


@payload(events.GRASP_DAMPED)
class GraspDamped(_Payload):
    """The arm locked at t [s]: the arm's displacement [m] and rotation vector [rad] in chaser_body axes (the
    contact's peaks follow as extra keys)."""

    t: float
    damping_time_s: float
    arm_displacement_body_m: Vector
    arm_rotation_body_rad: Vector


@payload(events.FAULT_INJECTED)
class FaultInjected(_Payload):
    """The simulator began fault number ``fault`` of the scenario's list at t_start [s] (flyby_sim.faults): its kind,
    what it acts on ('thruster 3', 'imu'), its duration [s] (None: permanent) and its value."""

    fault: int
    kind: str
    target: str
    t_start: float
    duration_s: float | None = None
    value: float | None = None


@payload(events.FAULT_ENDED)
class FaultEnded(_Payload):
    """The simulator ended fault number ``fault`` at t_end [s]."""

    fault: int
    kind: str
    target: str
    t_end: float


@payload(events.FAULT_DETECTED)
class FaultDetected(_Payload):
    """A health monitor detected (fault_detected) or saw the end of (fault_recovered) a fault of ``kind`` on
    ``component`` at t [s] (flyby_estimation.health; the rule's figures follow as extra keys)."""

    monitor: str
    kind: str
    component: str
    t: float
    candidates: Vector | None = None  # a thrust fault's candidate thrusters, a wheel fault's wheels


@payload(events.FAULT_RECOVERED)
class FaultRecovered(FaultDetected):
    """The monitor's rule has held within its bound again (its fault_detected's kind and component)."""


@payload(events.FAULT_RESPONSE)
class FaultResponse(_Payload):
    """The supervisor's answer to a detection (flyby_mission.fault_table): the response in the phase, the FMECA's
    severity (None: not in the table) and the detection's stamp [s]."""

    kind: str
    component: str
    response: str
    phase: str
    t_detected: float
    severity: int | None = None


@payload(events.NODE_ERROR)
class NodeError(_Payload):
    """A node's core raised (flyby_msgs_py.core_guard): the node, the exception's type and the input (topic, service
    or timer) it was handling."""

    node: str
    exception: str
    callback: str


@payload(events.PROPULSION_IDLED)
class PropulsionIdled(_Payload):
    """Guidance commands no burn and no thrust from the supervisor's node_error on (its stamp [s], its exception)."""

    t_error_s: float
    exception: str


@payload(events.MANEUVER_COMMANDED)
class ManeuverCommanded(_Payload):
    """Guidance sent a burn (guidance/maneuver): its kind (injection, adjust), start t_burn [s] and dv_hill [m/s]. The
    plant flies what it was sent, whatever follows (only the CAM cancels): the supervisor's abort coasts through it
    (flyby_mission.abort_escape)."""

    kind: str
    t_burn_s: float
    dv_hill_mps: Vector


@payload(events.THRUSTERS_ISOLATED)
class ThrustersIsolated(_Payload):
    """The supervisor closes these thrusters' valves (the plant gives them no thrust and allocates without them)."""

    thrusters: Vector


@payload(events.WHEELS_REALLOCATED)
class WheelsReallocated(_Payload):
    """The supervisor takes these wheels out of the attitude control (a wheel fault's ``reallocate``): guidance
    commands them no torque and gives what they gave to the wheels left and the thrusters' couples."""

    wheels: Vector


@payload(events.DAMPING_COMPLETE)
class DampingComplete(_Payload):
    """The damping ended: the excitation from t_excitation_s [s], the settled wheel momentum [N m s, chaser_body]."""

    momentum_bound_kg_m2_s: float
    damping_time_s: float
    t_excitation_s: float
    excitation: str
    h_wheels_body_n_m_s: Vector


@payload(events.EXCITATION_SCHEDULED)
class ExcitationScheduled(_Payload):
    """The excitation without damping, from t_excitation_s [s]; the settled wheel momentum [N m s, chaser_body]."""

    t_excitation_s: float
    excitation: str
    h_wheels_body_n_m_s: Vector


@payload(events.MASS_PROPERTIES_ESTIMATED)
class MassPropertiesEstimated(_Payload):
    """The final estimate of the target's mass [kg], CoM from the chaser's CoM [m] (chaser_body), principal moments
    [kg m^2] and axes (q_body_from_principal), with 1-sigmas (further figures follow as extra keys)."""

    mass_kg: float
    mass_sigma_kg: float
    com_body_m: Vector
    com_sigma_m: Vector
    principal_moments_kg_m2: Vector
    principal_moments_sigma_kg_m2: Vector
    principal_axes_q: Vector


@payload(events.MASS_PROPERTIES_ESTIMATE)
class MassPropertiesEstimate(MassPropertiesEstimated):
    """An estimate before the final one (the same fields)."""


@payload(events.TRANSPORT_COM_ESTIMATE)
class TransportComEstimate(_Payload):
    """The combined body's CoM [m] from the chaser's (chaser_body) and its 1-sigma [m], coast_s [s] after the last
    firing; the navigation's 1-sigma of the CoM's position [m], its largest axis, and of its velocity [m/s], its
    largest direction (``TransportNavigation.velocity_sigma_mps``: with what it does not know of the CoM)."""

    com_body_m: Vector
    com_sigma_m: Vector
    coast_s: float
    position_sigma_m: float | None = None
    velocity_sigma_mps: float | None = None


@payload(events.TRANSPORT_PLANNED)
class TransportPlanned(_Payload):
    """The transport's plan before flying: its arrival [s], number of burns and fuel [kg]; seed 004 §3.2's three
    quantities it predicts at the arrival (position error [m], linear momentum relative to the goal [N s], angular
    momentum [kg m^2/s]); the time after the arrival by which it states the conditions hold [s]."""

    t_arrival_s: float
    burns: int
    fuel_kg: float
    predicted_position_error_m: float
    predicted_momentum_error_n_s: float
    predicted_angular_momentum_kg_m2_s: float
    settle_bound_s: float | None = None


@payload(events.TRANSPORT_TERMINAL)
class TransportTerminal(_Payload):
    """A terminal firing after the last push: its impulse [N s], the horizon it solves over [s], and the linear
    momentum relative to the goal [N s] and distance from the goal [m] it predicts at the horizon."""

    impulse_n_s: float
    horizon_s: float
    predicted_momentum_n_s: float
    predicted_position_m: float


@payload(events.TRANSPORT_COMPLETE)
class TransportComplete(_Payload):
    """Guidance judged the transport (seed 004 §3.2) from the estimate: the CoM's distance from the goal [m], its
    linear momentum relative to the goal's circular motion [N s], the combined body's own angular momentum about its
    CoM, wheels excluded [kg m^2/s], the wheels' momentum [N m s] and the largest share of a wheel's capacity it
    uses; the planned arrival [s] and goal (hill [m]), the time from the arrival to now [s] and the bound the plan
    stated for it, how long the conditions held [s] and whether they are met."""

    position_error_m: float
    momentum_error_n_s: float
    angular_momentum_kg_m2_s: float
    wheel_momentum_n_m_s: float
    wheel_momentum_share: float
    t_arrival_s: float
    goal_hill_m: Vector
    settle_time_s: float
    held_s: float
    conditions_met: bool
    settle_bound_s: float | None = None


@payload(events.MESSAGE_REJECTED)
class MessageRejected(_Payload):
    """A node refused a message of ``topic`` (flyby_msgs_py.admission): the reason, how many of the topic's messages
    it has refused for that reason so far, and the refused message's stamp [s]."""

    topic: str
    reason: str
    count: int
    t_stamp_s: float


PAYLOADS = {cls.NAME: cls for cls in (PhaseChanged, PlanSelected, PlanRefused, TargetRefined, StationReached,
                                      AttitudeSynchronized, DockingStarted, GraspDamped, FaultInjected,
                                      FaultEnded, FaultDetected, FaultRecovered, FaultResponse,
                                      NodeError, PropulsionIdled, ManeuverCommanded, ThrustersIsolated,
                                      WheelsReallocated, DampingComplete,
                                      ExcitationScheduled, MassPropertiesEstimated, MassPropertiesEstimate,
                                      TransportComEstimate, TransportPlanned, TransportTerminal, TransportComplete,
                                      MessageRejected)}


@functools.cache
def _kind(cls, name):
    """A field's type without Optional: float, int, str, bool or Vector."""
    hint = typing.get_type_hints(cls)[name]
    args = [a for a in typing.get_args(hint) if a is not type(None)]
    return args[0] if isinstance(hint, types.UnionType) else hint


def _wire_key(f):
    return f.metadata.get('key', f.name)


def encode(record, extra=None):
    """The values of the record's event: its fields by their keys (None ones left out), then ``extra`` (keys the
    record does not model) untouched."""
    out = {_wire_key(f): getattr(record, f.name) for f in dataclasses.fields(record)
           if getattr(record, f.name) is not None}
    clash = set(out) & set(extra or {})
    if clash:
        raise ValueError(f'{record.NAME}: extra keys {sorted(clash)} are fields of the payload')
    return {**out, **(extra or {})}


def _parse(kind, value):
    """One value, as text (wire.value_text) or as a number, of the given kind."""
    if kind is Vector:
        return tuple(json.loads(value)) if isinstance(value, str) else _vector(value)
    if kind is bool:
        return value == 'true' if isinstance(value, str) else bool(value)
    if kind is str:
        return value
    return kind(value)


def decode_values(name, values):
    """The payload record of the event ``name`` from its values (text or numbers; keys it does not model
    ignored). Raises KeyError for a name without a payload, or a required key that is absent."""
    cls = PAYLOADS[name]
    return cls(**{f.name: _parse(_kind(cls, f.name), values[_wire_key(f)])
                  for f in dataclasses.fields(cls) if _wire_key(f) in values or f.default is dataclasses.MISSING})


def decode(event):
    """The payload record of a wire.Event (its name and values)."""
    return decode_values(event.name, event.values)
