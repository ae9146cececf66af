"""The engine's limits on hostile input: file size, alias expansion, nesting, the length of a value shown in a
message, and no coercion of strings to booleans or numbers."""

import os
import time

import pytest

from flyby_msgs_py import schema
from flyby_msgs_py.schema.loading import MAX_YAML_BYTES

ENUM = schema.Section(desc='A toy', fields={
    'model': schema.Field(schema.ENUM, 'a', None, 'A model.', choices=('a', 'b')),
    'flag': schema.Field(schema.BOOL, False, None, 'A flag.'),
    'gain': schema.Field(schema.FLOAT, 1.0, None, 'A gain.'),
    'count': schema.Field(schema.INT, 1, None, 'A count.'),
})


def _laughs(key='model'):
    """A 'billion laughs' alias chain: ten levels of nine aliases, 9**10 strings once expanded."""
    lines = ['l0: &l0 ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for i in range(1, 10):
        lines.append(f'l{i}: &l{i} [' + ','.join([f'*l{i - 1}'] * 9) + ']')
    return '\n'.join(lines) + f'\n{key}: *l9\n'


def _refusal(path):
    start = time.perf_counter()
    with pytest.raises(schema.ScenarioError) as err:
        schema.load_yaml_mapping(path)
    return str(err.value), time.perf_counter() - start


def test_load_refuses_a_billion_laughs_alias_chain_in_well_under_a_second(tmp_path):
    path = tmp_path / 'laughs.yaml'
    path.write_text(_laughs())
    message, seconds = _refusal(path)
    assert message == f'{path}: YAML error: aliases (*name) expand the document by more than 100000 values (at model)'
    assert seconds < 0.5


def test_load_refuses_an_alias_inside_its_own_value(tmp_path):
    path = tmp_path / 'recursive.yaml'
    path.write_text('a: &a [1, *a]\n')
    message, _ = _refusal(path)
    assert message == f'{path}: YAML error: an alias refers to the value that contains it'


def test_load_keeps_a_few_aliases_and_merge_keys(tmp_path):
    path = tmp_path / 'aliases.yaml'
    path.write_text('a: &a [1, 2, 3]\nb: *a\nc: {<<: {x: 1}, y: 2}\n')
    assert schema.load_yaml_mapping(path) == {'a': [1, 2, 3], 'b': [1, 2, 3], 'c': {'x': 1, 'y': 2}}


def test_load_refuses_a_5_mb_list_under_an_unknown_key_fast_by_its_size(tmp_path):
    path = tmp_path / 'big.yaml'
    path.write_text('model: a\nunknown: [' + ','.join(['1'] * 2_600_000) + ']\n')
    message, seconds = _refusal(path)
    assert message == (f'{path}: file is {path.stat().st_size} bytes, more than the {MAX_YAML_BYTES} bytes (1 MiB) '
                       'a scenario or campaign file may hold')
    assert seconds < 0.5


def test_load_refuses_values_nested_too_deeply(tmp_path):
    path = tmp_path / 'deep.yaml'
    path.write_text('a: ' + '[' * 5_000 + ']' * 5_000 + '\n')
    message, _ = _refusal(path)
    assert message.startswith(f'{path}: YAML ')
    assert '\n' not in message


def test_enum_error_shows_a_huge_value_cut_to_one_short_line():
    with pytest.raises(schema.Invalid) as err:
        schema.validate(ENUM, {'model': [['lol'] * 1000] * 1000})
    assert err.value.key == 'model'
    assert len(err.value.problem) < 200
    assert err.value.problem.endswith('...')


def test_describe_cuts_a_long_string():
    text = schema.describe('x' * 1_000_000)
    assert text.startswith("string 'xxx") and len(text) < 100


@pytest.mark.parametrize('key,value,problem', [
    ('flag', 'no', "must be true or false, got string 'no'"),
    ('flag', 'yes', "must be true or false, got string 'yes'"),
    ('flag', 1, 'must be true or false, got 1'),
    ('gain', True, 'must be a number, got true (bool)'),
    ('gain', '1.5', "must be a number, got string '1.5'"),
    ('count', False, 'must be an integer, got false (bool)'),
    ('count', '3', "must be an integer, got string '3'"),
])
def test_validate_refuses_strings_and_bools_coerced_to_another_kind(key, value, problem):
    with pytest.raises(schema.Invalid) as err:
        schema.validate(ENUM, {key: value})
    assert (err.value.key, err.value.problem) == (key, problem)


def test_a_yaml_no_is_a_string_not_a_boolean(tmp_path):
    """YAML 1.1's yes/no/on/off are read as booleans by PyYAML; quoted, they stay strings and are refused."""
    path = tmp_path / 'flag.yaml'
    path.write_text("flag: 'no'\n")
    with pytest.raises(schema.Invalid) as err:
        schema.validate(ENUM, schema.load_yaml_mapping(path))
    assert err.value.problem == "must be true or false, got string 'no'"


def test_load_refuses_a_pipe_that_would_block(tmp_path):
    path = tmp_path / 'pipe.yaml'
    os.mkfifo(path)
    message, seconds = _refusal(path)
    assert message == f'{path}: not a regular file'
    assert seconds < 0.5


def test_load_reads_yes_no_on_off_as_strings_not_booleans(tmp_path):
    """YAML 1.2 booleans: only true and false; a BOOL key written `no` is then refused, not read as false."""
    path = tmp_path / 'flags.yaml'
    path.write_text('a: no\nb: yes\nc: on\nd: off\ne: true\nf: False\n')
    assert schema.load_yaml_mapping(path) == {'a': 'no', 'b': 'yes', 'c': 'on', 'd': 'off', 'e': True, 'f': False}
    path.write_text('flag: no\n')
    with pytest.raises(schema.Invalid) as err:
        schema.validate(ENUM, schema.load_yaml_mapping(path))
    assert err.value.problem == "must be true or false, got string 'no'"


POSITIVE = schema.Section(desc='A toy', fields={
    'gain': schema.Field(schema.FLOAT, 1.0, '> 0', 'A gain.'),
    'noise': schema.Field(schema.FLOAT, 0.0, '>= 0', 'A noise.'),
    'offset': schema.Field(schema.VEC3, (0.0, 0.0, 0.0), None, 'An offset.'),
})


@pytest.mark.parametrize('key,value,problem', [
    ('gain', 1e300, 'must be at most 1e+30 in magnitude'),
    ('gain', 1e-300, 'must be at least 1e-30 (it must be > 0'),
    ('noise', 1e31, 'must be at most 1e+30 in magnitude'),
    ('offset', [0.0, -1e300, 0.0], 'must be at most 1e+30 in magnitude'),
])
def test_validate_refuses_a_number_beyond_1e30_or_a_positive_one_below_1e_minus_30(key, value, problem):
    with pytest.raises(schema.Invalid) as err:
        schema.validate(POSITIVE, {key: value})
    assert problem in err.value.problem, err.value.problem


def test_validate_keeps_a_tiny_value_where_zero_is_allowed():
    resolved = schema.validate(POSITIVE, {'noise': 1e-300, 'offset': [1e-72, 0.0, 1.0]})
    assert resolved['noise'] == 1e-300 and resolved['offset'][0] == 1e-72


def test_validate_refuses_an_integer_beyond_a_double_for_a_number_key():
    with pytest.raises(schema.Invalid) as err:
        schema.validate(POSITIVE, {'gain': 10**400})
    assert (err.value.key, err.value.problem[:15]) == ('gain', 'must be finite,')
