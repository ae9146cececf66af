"""The supervisor's answer to a health monitor's ``fault_detected``: the fault table's response in the phase
(docs/faults.md), as events and the transition it causes.

``respond`` returns a ``Reply``: the ``fault_response`` event (ERROR where the mission changes, WARN where it goes
on), the ``thrusters_isolated`` event where the response closes the candidate thrusters (the simulator closes their
valves), the ``wheels_reallocated`` event where it takes the named wheels out of the attitude control (guidance
commands them nothing and gives their axes' torque to the wheels left and the thrusters' couples: docs/faults.md),
whether to abort, and the fault a ``hold`` or ``retreat`` waits on (the phase machine holds standby, or gives the
approach up, until that fault's ``fault_recovered``). The machine's other rule (an ERROR event of a watched node
aborts) does not apply to a detection: the table answers it. It does apply to guidance's refusal of a reallocation (an
ERROR ``command_rejected`` once the wheels left span fewer than three axes, or for an index that is no wheel: guidance
knows the wheels' geometry, the supervisor does not), which aborts after this module's ``reallocate``.
"""

import typing

from flyby_mission.fault_table import Answer, FaultTable
from flyby_msgs_py import event_payloads, events


class Reply(typing.NamedTuple):
    """The fault table's answer as the supervisor acts on it."""

    events: list  # (level, name, message, values) to publish
    abort: str | None  # the abort's reason, or None
    hold: tuple | None  # (kind, component) of the fault a hold waits on, or None
    retreat: tuple | None  # (kind, component) of the fault a retreat waits on, or None


def respond(table: FaultTable, event, phase, cam_fired=False):
    """The Reply to the wire event ``fault_detected`` in ``phase``. After the independent monitor's CAM (cam_fired)
    the answer is ``continue``: its burn is thrust the flight software did not command, and closing the thrusters
    that give it would undo it. An ``isolate`` with no candidate thruster to close, or a ``reallocate`` naming no
    wheel, is an ``abort``."""
    detected = event_payloads.decode(event)
    answer = table.response(detected.kind, detected.component, phase)
    candidates = [int(i) for i in detected.candidates or ()]
    if cam_fired:
        answer = Answer('continue', answer.severity, 'the CAM has the thrusters')
    elif answer.response in ('isolate', 'isolate_abort') and not candidates:
        answer = Answer('abort', answer.severity, f'{answer.effect}; no candidate thruster to close')
    elif answer.response == 'reallocate' and not candidates:
        answer = Answer('abort', answer.severity, f'{answer.effect}; no wheel named to take out')
    payload = event_payloads.FaultResponse(detected.kind, detected.component, answer.response, phase, event.t,
                                           answer.severity)
    why = answer.effect or 'not in the fault table'
    out = [('WARN' if answer.response == 'continue' else 'ERROR', events.FAULT_RESPONSE,
            f'{detected.kind} on {detected.component} in {phase}: {answer.response} ({why})',
            event_payloads.encode(payload))]
    if answer.response in ('isolate', 'isolate_abort'):
        out.append(('WARN', events.THRUSTERS_ISOLATED, f'thrusters {candidates} isolated: {detected.kind}',
                    event_payloads.encode(event_payloads.ThrustersIsolated(tuple(candidates)))))
    if answer.response == 'reallocate':
        out.append(('WARN', events.WHEELS_REALLOCATED, f'wheels {candidates} out of the attitude control, their '
                    f'torque to the wheels left and the thrusters: {detected.kind}',
                    event_payloads.encode(event_payloads.WheelsReallocated(tuple(candidates)))))
    abort = answer.response in ('abort', 'isolate_abort')
    fault = (detected.kind, detected.component)
    return Reply(out, f'{detected.kind} on {detected.component}: the fault table answers {answer.response}'
                 if abort else None, fault if answer.response == 'hold' else None,
                 fault if answer.response == 'retreat' else None)
