"""The ``faults`` list of the flyby scenario schema (``scenario.schema``; docs/faults.md): what may fail, where,
when and how much. Its own module because it is a block of its own (the kinds, sensors, nodes and topics are
``flyby_sim.faults``'s), and the schema was past the size a module may have."""

from flyby_msgs_py.admission import MAX_AGE_S
from flyby_msgs_py.schema import ENUM, FLOAT, INT, REQUIRED, VEC3, Field, ListOf, Section
from flyby_sim.faults import KINDS as FAULT_KINDS
from flyby_sim.faults import NODES as FAULT_NODES
from flyby_sim.faults import PHASES as FAULT_PHASES
from flyby_sim.faults import SENSORS as FAULT_SENSORS
from flyby_sim.faults import TOPICS as FAULT_TOPICS

FAULTS = ListOf(
    desc='Faults injected into the plant (docs/faults.md); omitted: none', optional=True,
    item=Section(desc='One fault', fields={
        'type': Field(ENUM, REQUIRED, None, 'What fails (docs/faults.md): thrusters and wheels of the rigid_body '
                                            'chaser by index, sensors, nodes and topics by name.',
                      choices=FAULT_KINDS),
        'index': Field(INT, None, '>= 0', 'The thruster (chaser.thrusters.layout order, the default 12 '
                                          'otherwise) or the wheel (chaser.wheels.axes order).'),
        'sensor': Field(ENUM, None, None, 'The sensor of sensor_dropout and sensor_outliers (imu: the gyro and '
                                          'the accelerometer, sampled together).', choices=FAULT_SENSORS),
        'start_s': Field(FLOAT, None, '>= 0', 'It begins at this sim time (give this or start_phase) ...'),
        'start_phase': Field(ENUM, None, None, '... or when this phase begins (its first start) ...',
                             choices=FAULT_PHASES),
        'delay_s': Field(FLOAT, 0.0, '>= 0', '... plus this delay.'),
        'duration_s': Field(FLOAT, None, '>= 0', 'How long it lasts; omitted: to the run\'s end.'),
        'value': Field(FLOAT, None, None, 'How much, by type (docs/faults.md: topic_delay\'s delay [s], at most '
                                          f'{MAX_AGE_S:g}); omitted: the type\'s default.'),
        'axis': Field(VEC3, None, None, 'The misalignment\'s rotation axis or the bias jump\'s direction, '
                                        'chaser_body; omitted: drawn from the seed.'),
        'node': Field(ENUM, None, None, 'The node of node_crash: killed at the start, respawned at the end.',
                      choices=tuple(FAULT_NODES)),
        'topic': Field(ENUM, None, None, 'The topic of topic_delay and topic_loss: its messages stamped in the '
                                         'window reach their subscribers late, or never.', choices=FAULT_TOPICS),
    }))
