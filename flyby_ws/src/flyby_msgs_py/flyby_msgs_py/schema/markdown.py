"""The key table of a docs page, rendered from a schema."""

from flyby_msgs_py.schema.blocks import (
    ENUM,
    FLOAT_LIST,
    MAT3,
    QUAT,
    REQUIRED,
    VEC3,
    VEC3_LIST,
    Field,
    ListOf,
    Section,
    _is_required,
    unit_of,
)
from flyby_msgs_py.schema.validation import _join


def _fmt_default(node, alternative):
    if alternative:
        return 'one of'
    if isinstance(node, Field):
        d = node.default
        if d is REQUIRED:
            return '**required**'
        if isinstance(d, tuple) and d and isinstance(d[0], tuple):
            return '[' + ', '.join('[' + ', '.join(f'{x:g}' for x in row) + ']' for row in d) + ']'
        if isinstance(d, tuple):
            return '[' + ', '.join(f'{x:g}' for x in d) + ']'
        if isinstance(d, str):
            return f"'{d}'"
        return f'{d:.10g}' if isinstance(d, float) else str(d)
    if getattr(node, 'optional', False):
        return '(optional)'
    return '**required**' if _is_required(node) else '(defaults)'


def _fmt_type(node):
    if isinstance(node, ListOf):
        return 'list of mappings'
    if isinstance(node, Section):
        return 'mapping'
    if node.kind == ENUM:
        return ' \\| '.join(f"'{c}'" for c in node.choices)
    return node.kind


def _schema_rows(section, prefix):
    alt = section.alternatives
    for k, node in section.fields.items():
        key = _join(prefix, k)
        if isinstance(node, Field):
            rng = node._range.describe() if node._range is not None else ''
            if node.kind in (VEC3, QUAT, MAT3, VEC3_LIST, FLOAT_LIST) and not rng:
                rng = 'finite'
            elif node.kind in (VEC3, QUAT, VEC3_LIST, FLOAT_LIST) and rng:
                rng = f'each {rng}'
            yield key, _fmt_type(node), unit_of(k), _fmt_default(node, k in alt), rng, node.desc
        else:
            note = ''
            if isinstance(node, Section) and node.one_of:
                note = ' Exactly one of ' + '; '.join(', '.join(f'`{x}`' for x in g) for g in node.one_of) + '.'
            yield key, _fmt_type(node), '', _fmt_default(node, k in alt), \
                'non-empty' if isinstance(node, ListOf) else '', node.desc + '.' + note
            inner = node.item if isinstance(node, ListOf) else node
            yield from _schema_rows(inner, f'{key}[]' if isinstance(node, ListOf) else key)


def schema_markdown(schema):
    """A markdown table of every key of ``schema``: key, type, unit, default, range, meaning."""
    lines = ['| key | type | unit | default | range | meaning |', '|---|---|---|---|---|---|']
    for key, kind, unit, default, rng, desc in _schema_rows(schema, ''):
        lines.append(f'| `{key}` | {kind} | {unit} | {default} | {rng} | {desc} |')
    return '\n'.join(lines) + '\n'
