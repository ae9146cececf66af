"""Typed, frozen parameter records of the cores, derived from the scenario schema (one declaration per key).

The scenario schema (``flyby_sim.scenario.SCHEMA``) declares every key once: its kind, default, range and
description, as generate_parameter_library's YAML does for a ROS node. A core does not take the whole scenario: it
takes one frozen record of what it reads, whose fields name the schema key they come from and declare nothing else
(no default, no range: the schema's hold, and the loader has filled and checked them)::

    @params.record
    class DampingParams:
        velocity_tolerance_mps: float = params.key('post_capture.grasp.velocity_tolerance_mps')
        direction_error_sigma_rad: float = params.key('chaser.thrusters.direction_error_sigma_deg', math.radians)
        n_rad_s: float = params.key('mean_motion_rad_s')            # a quantity the Scenario derives
        layout: object = params.derived(thruster_layout_of)          # several keys combined by a function
        transport: TransportParams = params.sub(TransportParams, when=has_transport)

    DampingParams.from_scenario(scenario)

``describe(record, schema)`` gives each field's key, kind, default, range and description from the schema;
``keys_of(record)`` every key a record reads. No ROS here.
"""

import dataclasses

_KEY, _CONVERT, _DERIVE, _RECORD, _WHEN = 'key', 'convert', 'derive', 'record', 'when'


def key(path, convert=None):
    """A field read from the scenario at the dotted ``path`` (a schema key, e.g. ``planner.offset_m``, or a
    quantity the Scenario derives, e.g. ``mean_motion_rad_s``), through ``convert`` when given (e.g. a unit).
    A path through an optional section left out reads None."""
    return dataclasses.field(metadata={_KEY: path, _CONVERT: convert})


def derived(function):
    """A field computed from the whole scenario by ``function(scenario)``: several keys combined."""
    return dataclasses.field(metadata={_DERIVE: function})


def sub(record_type, when=None):
    """A field that is another record, built from the same scenario; None where ``when(scenario)`` is false."""
    return dataclasses.field(metadata={_RECORD: record_type, _WHEN: when})


def record(cls):
    """A frozen dataclass of scenario-derived fields (module doc), with ``from_scenario(scenario)``. Every field
    must say where it comes from (``key``, ``derived`` or ``sub``)."""
    cls = dataclasses.dataclass(frozen=True)(cls)
    for f in dataclasses.fields(cls):
        if not ({_KEY, _DERIVE, _RECORD} & set(f.metadata)):
            raise TypeError(f'{cls.__name__}.{f.name}: a parameter field says its key (params.key, derived or sub)')
    cls.from_scenario = classmethod(from_scenario)
    return cls


def is_record(cls):
    return dataclasses.is_dataclass(cls) and getattr(cls, 'from_scenario', None) is not None


def _read(scenario, path):
    value = scenario
    for part in path.split('.'):
        if value is None:
            return None
        value = getattr(value, part)
    return value


def from_scenario(cls, scenario):
    """The record ``cls`` of a validated scenario (module doc)."""
    values = {}
    for f in dataclasses.fields(cls):
        m = f.metadata
        if _KEY in m:
            v = _read(scenario, m[_KEY])
            values[f.name] = m[_CONVERT](v) if m[_CONVERT] is not None and v is not None else v
        elif _DERIVE in m:
            values[f.name] = m[_DERIVE](scenario)
        else:
            when = m[_WHEN]
            values[f.name] = None if when is not None and not when(scenario) else m[_RECORD].from_scenario(scenario)
    return cls(**values)


def keys_of(cls, prefix=''):
    """(field path, key path) of every ``key`` field of a record and its sub-records."""
    out = []
    for f in dataclasses.fields(cls):
        if _KEY in f.metadata:
            out.append((prefix + f.name, f.metadata[_KEY]))
        elif _RECORD in f.metadata:
            out.extend(keys_of(f.metadata[_RECORD], f'{prefix}{f.name}.'))
    return out


def schema_field(schema, path):
    """The schema's declaration (Field, Section or ListOf) of a dotted key path, or None if it is not a key."""
    node = schema
    for part in path.split('.'):
        fields = getattr(node, 'fields', None)
        if fields is None or part not in fields:
            return None
        node = fields[part]
    return node


def describe(cls, schema):
    """Rows (field, key, kind, default, range, description) of a record's key fields, from the schema; a derived
    quantity of the Scenario reads kind 'derived'."""
    rows = []
    for field, path in keys_of(cls):
        node = schema_field(schema, path)
        if node is None or not hasattr(node, 'kind'):
            rows.append((field, path, 'derived', None, None, ''))
        else:
            rows.append((field, path, node.kind, node.default, node.range, node.desc))
    return rows
