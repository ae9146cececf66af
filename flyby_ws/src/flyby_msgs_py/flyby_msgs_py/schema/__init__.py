"""A declarative schema for YAML configuration files: validation, strict loading, a read-only view, docs.

A schema is a tree of ``Section`` (a mapping of keys), ``ListOf`` (a non-empty list of mappings) and
``Field`` (one leaf: kind, default or REQUIRED, range text, one-line description). A Section or ListOf
marked ``optional`` may be left out (or written as null): it then resolves to None, and the code that
reads it supplies what its absence means. The engine knows
no particular key; the flyby scenario schema that uses it is ``flyby_sim.scenario.SCHEMA``.

    data = load_yaml_mapping('scenarios/x.yaml')   # strict YAML, one-line ScenarioError on any problem
    resolved = validate(SCHEMA, data)               # defaults filled in, or Invalid(key, problem)
    view = Namespace(resolved, SCHEMA)              # view.chaser.mass_kg, read-only
    schema_markdown(SCHEMA)                         # the key table of a docs page

Every problem of a file is a ``ScenarioError`` (a ``ValueError``) whose message is one line naming
the file, the dotted key path and the problem, e.g. ``scenarios/x.yaml: chaser.mass_kg: must be > 0,
got -5.0``. The unit of a key comes from its name's suffix (STYLE.md: units live in the names).

The modules: ``blocks`` (the errors, the building blocks Field, Section, ListOf and the checks any schema may use),
``validation``, ``loading`` (strict YAML), ``view`` (Namespace) and ``markdown`` (the key table).
"""

from flyby_msgs_py.schema.blocks import (
    BOOL,
    ENUM,
    FLOAT,
    FLOAT_LIST,
    INT,
    KINDS,
    MAT3,
    QUAT,
    REQUIRED,
    STR,
    VEC3,
    VEC3_LIST,
    Field,
    Invalid,
    ListOf,
    Range,
    ScenarioError,
    Section,
    check_nonempty,
    check_nonzero,
    describe,
    format_floats,
    short_repr,
    unit_of,
)
from flyby_msgs_py.schema.loading import load_yaml_mapping
from flyby_msgs_py.schema.markdown import schema_markdown
from flyby_msgs_py.schema.validation import MAGNITUDE_RANGE, validate, validate_field
from flyby_msgs_py.schema.view import Namespace

__all__ = ['BOOL', 'ENUM', 'FLOAT', 'FLOAT_LIST', 'INT', 'KINDS', 'MAGNITUDE_RANGE', 'MAT3', 'QUAT', 'REQUIRED', 'STR',
           'VEC3', 'VEC3_LIST', 'Field', 'Invalid', 'ListOf', 'Namespace', 'Range', 'ScenarioError', 'Section',
           'check_nonempty', 'check_nonzero', 'describe', 'format_floats', 'load_yaml_mapping', 'schema_markdown',
           'short_repr', 'unit_of', 'validate', 'validate_field']
