"""The schema engine on a schema of its own (no flyby key): validation, the view and its pickling, the
YAML loader, the rendered table. The flyby schema's tests are flyby_sim/test/test_scenario.py."""

import copy
import pickle

import numpy as np
import pytest

from flyby_msgs_py import schema

TOY = schema.Section(desc='A toy', fields={
    'label': schema.Field(schema.STR, schema.REQUIRED, desc='A name.'),
    'arm': schema.Section(desc='An arm', one_of=(('length_m', 'length_mm'),), fields={
        'length_m': schema.Field(schema.FLOAT, schema.REQUIRED, '> 0', 'Length.'),
        'length_mm': schema.Field(schema.FLOAT, schema.REQUIRED, '> 0', 'Length in mm.'),
        'tip_m': schema.Field(schema.VEC3, (0.0, 0.0, 1.0), None, 'Tip position.', check=schema.check_nonzero),
    }),
    'joints': schema.ListOf(desc='Joints', item=schema.Section(desc='One joint', fields={
        'rate_hz': schema.Field(schema.FLOAT, 10.0, '(0, 100]', 'Rate.'),
    })),
})


def test_validate_fills_defaults_and_leaves_out_alternatives_not_given():
    resolved = schema.validate(TOY, {'label': 'a', 'arm': {'length_m': 2}, 'joints': [{}, {'rate_hz': 5}]})
    assert resolved == {'label': 'a', 'arm': {'length_m': 2.0, 'tip_m': [0.0, 0.0, 1.0]},
                        'joints': [{'rate_hz': 10.0}, {'rate_hz': 5.0}]}


@pytest.mark.parametrize('data,key,problem', [
    ({'label': 'a', 'arm': {'length_m': 1.0}, 'joints': [{}], 'lable': 'b'}, 'lable',
     "unknown key (did you mean 'label'?)"),
    ({'label': 'a', 'arm': {}, 'joints': [{}]}, 'arm',
     "exactly one of 'length_m', 'length_mm' must be given, got none"),
    ({'label': 'a', 'arm': {'length_m': 1.0}, 'joints': [{'rate_hz': 0}]}, 'joints[0].rate_hz',
     'must be in (0, 100], got 0.0'),
    ({'label': 'a', 'arm': {'length_m': 1.0, 'tip_m': [0, 0, 0]}, 'joints': [{}]}, 'arm.tip_m',
     'must be nonzero, got [0.0, 0.0, 0.0]'),
    ({'arm': {'length_m': 1.0}, 'joints': [{}]}, 'label', 'missing required key'),
])
def test_validate_names_the_key_and_the_problem(data, key, problem):
    with pytest.raises(schema.Invalid) as info:
        schema.validate(TOY, data)
    assert (info.value.key, info.value.problem) == (key, problem)


def test_namespace_carries_its_schema_through_pickle_and_deepcopy():
    view = schema.Namespace(schema.validate(TOY, {'label': 'a', 'arm': {'length_mm': 20.0}, 'joints': [{}]}), TOY)
    for other in (pickle.loads(pickle.dumps(view)), copy.deepcopy(view)):
        assert other == view
        assert other.arm.length_m is None and other.arm.length_mm == 20.0  # an alternative not given
        assert other.joints[0].rate_hz == 10.0
        np.testing.assert_array_equal(other.arm.tip_m, [0.0, 0.0, 1.0])
        with pytest.raises(AttributeError, match="arm has no key 'width_m'"):
            other.arm.width_m  # noqa: B018 - reading the key is what raises
    with pytest.raises(AttributeError, match='read-only'):
        view.label = 'b'


def test_field_kind_is_checked():
    with pytest.raises(ValueError, match="Field kind 'vector' is not one of"):
        schema.Field('vector')


def test_load_yaml_mapping_one_line_errors(tmp_path):
    p = tmp_path / 'x.yaml'
    p.write_text('a: 1\nb: [2\n')
    with pytest.raises(schema.ScenarioError, match=r'x.yaml: YAML syntax error at line '):
        schema.load_yaml_mapping(p)
    p.write_text('a: 1\na: 2\n')
    with pytest.raises(schema.ScenarioError, match=r"x.yaml: YAML error at line 2, column 1: .*duplicate key 'a'"):
        schema.load_yaml_mapping(p)
    p.write_text('x: 7e6\n')
    assert schema.load_yaml_mapping(p) == {'x': 7e6}
    with pytest.raises(schema.ScenarioError, match='nope.yaml: file not found$'):
        schema.load_yaml_mapping(tmp_path / 'nope.yaml')


def test_schema_markdown_rows_with_units_from_the_key_names():
    table = schema.schema_markdown(TOY).splitlines()
    assert table[0] == '| key | type | unit | default | range | meaning |'
    assert '| `arm.length_mm` | float |  | one of | > 0 | Length in mm. |' in table
    assert '| `arm.length_m` | float | m | one of | > 0 | Length. |' in table
    assert '| `joints[].rate_hz` | float | Hz | 10 | in (0, 100] | Rate. |' in table
    assert '| `arm.tip_m` | 3-vector | m | [0, 0, 1] | finite | Tip position. |' in table
