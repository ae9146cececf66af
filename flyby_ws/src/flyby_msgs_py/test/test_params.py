"""Parameter records from a schema of their own (no flyby key): keys, units, derived fields, sub-records, the
schema's description of each field, and the refusal of a field that says no key."""

import dataclasses
import math

import pytest

from flyby_msgs_py import params, schema

TOY = schema.Section(desc='A toy', fields={
    'label': schema.Field(schema.STR, schema.REQUIRED, desc='A name.'),
    'arm': schema.Section(desc='An arm', fields={
        'length_m': schema.Field(schema.FLOAT, 1.5, '> 0', 'Length.'),
        'bend_deg': schema.Field(schema.FLOAT, 90.0, '[0, 180]', 'Bend.'),
    }),
    'gripper': schema.Section(desc='A gripper', optional=True, fields={
        'force_n': schema.Field(schema.FLOAT, 10.0, '> 0', 'Grip force.'),
    }),
})


def _view(data):
    return schema.Namespace(schema.validate(TOY, data), TOY)


@params.record
class GripperParams:
    force_n: float = params.key('gripper.force_n')


@params.record
class ArmParams:
    length_m: float = params.key('arm.length_m')
    bend_rad: float = params.key('arm.bend_deg', math.radians)
    reach_m: float = params.derived(lambda sc: sc.arm.length_m * math.sin(math.radians(sc.arm.bend_deg)))
    gripper: GripperParams = params.sub(GripperParams, when=lambda sc: sc.gripper is not None)
    gripper_force_n: float = params.key('gripper.force_n')


def test_a_record_reads_its_keys_with_the_schemas_defaults_units_and_derived_fields():
    p = ArmParams.from_scenario(_view({'label': 'a', 'arm': {'bend_deg': 30.0}}))
    assert p.length_m == 1.5  # the schema's default, declared nowhere else
    assert p.bend_rad == math.radians(30.0)
    assert p.reach_m == pytest.approx(0.75)
    assert p.gripper is None and p.gripper_force_n is None  # an optional section left out
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.length_m = 2.0


def test_a_sub_record_is_built_from_the_same_scenario():
    p = ArmParams.from_scenario(_view({'label': 'a', 'arm': {}, 'gripper': {'force_n': 4.0}}))
    assert p.gripper == GripperParams(4.0) and p.gripper_force_n == 4.0


def test_describe_gives_each_field_the_schemas_declaration():
    rows = {row[0]: row[1:] for row in params.describe(ArmParams, TOY)}
    assert rows['length_m'] == ('arm.length_m', schema.FLOAT, 1.5, '> 0', 'Length.')
    assert rows['gripper.force_n'] == ('gripper.force_n', schema.FLOAT, 10.0, '> 0', 'Grip force.')
    assert 'reach_m' not in rows  # derived: it has no key of its own
    assert params.keys_of(ArmParams) == [('length_m', 'arm.length_m'), ('bend_rad', 'arm.bend_deg'),
                                         ('gripper.force_n', 'gripper.force_n'),
                                         ('gripper_force_n', 'gripper.force_n')]


def test_a_field_that_says_no_key_is_refused():
    with pytest.raises(TypeError, match='Bad.length_m: a parameter field says its key'):
        @params.record
        class Bad:
            length_m: float = 1.5
