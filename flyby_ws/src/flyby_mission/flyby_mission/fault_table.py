"""The fault table: each detected fault's response by phase, generated from the FMECA in docs/faults.md.

``fault_table.yaml`` (beside this module) is written by ``scripts/fault_table.py`` from the FMECA's markdown table
(``fmeca_rows``); the supervisor loads it once (``FaultTable.load``) and answers each ``fault_detected`` with
``FaultTable.response``. A detection the table does not hold is answered ``abort``.
"""

import dataclasses
from pathlib import Path

import yaml

from flyby_msgs_py import contract as c

TABLE_PATH = Path(__file__).with_name('fault_table.yaml')
RESPONSES = ('continue', 'hold', 'retreat', 'abort', 'isolate', 'isolate_abort', 'reallocate')
# The responses that act on one component's candidates: isolate closes thrusters' valves, reallocate takes wheels out
# of the attitude control; on another component's row they would act on nothing (or on the wrong indices).
RESPONSE_COMPONENT = {'isolate': 'thrusters', 'isolate_abort': 'thrusters', 'reallocate': 'wheels'}
# The groups each response that waits for a recovery may answer in: a hold in standby, where nothing has been flown;
# a retreat in the approach, which it gives up (in the fly-by the passive arc needs nothing; after the capture the
# chaser holds the target).
WAITING_GROUPS = {'hold': ('standby',), 'retreat': ('approach',)}
PHASE_GROUPS = {
    'standby': (c.PHASE_ESTIMATION, c.PHASE_PLANNING) + c.WAITING_PHASES,
    'approach': (c.PHASE_TERMINAL_APPROACH, c.PHASE_TRAJECTORY_ADJUST, c.PHASE_OPTIMAL_APPROACH) + c.SYNC_PHASES,
    'flyby': (c.PHASE_FLYBY,),
    'after_capture': (c.PHASE_CAPTURE, c.PHASE_ESCAPE, c.PHASE_COMPLETE, c.PHASE_ABORTED) + c.POST_CAPTURE_PHASES,
}
COLUMNS = ('kind', 'component', 'effect', 'detection', 'severity', *PHASE_GROUPS)
BEGIN, END = '<!-- BEGIN FMECA -->', '<!-- END FMECA -->'
UNLISTED = 'abort'


@dataclasses.dataclass(frozen=True)
class Answer:
    """A detection's response in a phase, with its row's severity and effect (None: not in the table)."""

    response: str
    severity: int | None
    effect: str | None


def fmeca_rows(markdown):
    """The FMECA's rows (dicts of COLUMNS) from the markdown between BEGIN and END; ValueError naming the row for a
    malformed one (a cell count, a severity, a response unknown, on a component it cannot act on
    (RESPONSE_COMPONENT) or a hold or retreat outside its WAITING_GROUPS)."""
    if BEGIN not in markdown or END not in markdown:
        raise ValueError(f'the FMECA table must lie between {BEGIN} and {END}')
    lines = [x.strip() for x in markdown.split(BEGIN, 1)[1].split(END, 1)[0].strip().splitlines()]
    rows = []
    for n, line in enumerate(lines[2:], start=1):
        cells = [x.strip() for x in line.strip('|').split('|')]
        if len(cells) != len(COLUMNS):
            raise ValueError(f'FMECA row {n}: {len(cells)} cells, expected {len(COLUMNS)} ({", ".join(COLUMNS)})')
        row = dict(zip(COLUMNS, cells, strict=True))
        if not row['severity'].isdigit():
            raise ValueError(f'FMECA row {n} ({row["kind"]} {row["component"]}): severity {row["severity"]!r} is not '
                             f'a whole number (1 catastrophic, 2 critical, 3 marginal)')
        row['severity'] = int(row['severity'])
        for group in PHASE_GROUPS:
            if row[group] not in RESPONSES:
                raise ValueError(f'FMECA row {n} ({row["kind"]} {row["component"]}): {group} response '
                                 f'{row[group]!r} is not one of {", ".join(RESPONSES)}')
            allowed = WAITING_GROUPS.get(row[group])
            if allowed is not None and group not in allowed:
                raise ValueError(f'FMECA row {n} ({row["kind"]} {row["component"]}): {group} response '
                                 f'{row[group]}: answers in {", ".join(allowed)} only')
            needs = RESPONSE_COMPONENT.get(row[group])
            if needs is not None and row['component'] != needs:
                raise ValueError(f'FMECA row {n} ({row["kind"]} {row["component"]}): {group} response '
                                 f'{row[group]!r} acts on {needs} only, not on {row["component"]}')
        rows.append(row)
    return rows


class FaultTable:
    """The responses by (kind, component) and phase group (module doc)."""

    def __init__(self, rows):
        self.rows = {(r['kind'], r['component']): r for r in rows}

    @classmethod
    def load(cls, path=TABLE_PATH):
        return cls(yaml.safe_load(Path(path).read_text())['faults'])

    def response(self, kind, component, phase):
        """The Answer to a detection of ``kind`` on ``component`` (a thrust or wheel fault's component is
        'thrusters' or 'wheels', whatever its candidates) in ``phase``."""
        row = self.rows.get((kind, component.split(' ')[0]))
        if row is None:
            return Answer(UNLISTED, None, None)
        group = next((g for g, phases in PHASE_GROUPS.items() if phase in phases), 'after_capture')
        return Answer(row[group], row['severity'], row['effect'])
