"""What the mission publishes as text: its phase (std_msgs/String) and its events on /mission/events
(diagnostic_msgs/DiagnosticArray)."""

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from std_msgs.msg import String

from flyby_msgs_py.convert.fields import _describe
from flyby_msgs_py.convert.stamps import _stamp_into, stamp_to_sec
from flyby_msgs_py.wire import value_text


def string(data):
    """std_msgs/String (e.g. /mission/phase)."""
    if type(data) is not str:
        raise ValueError(f'data: must be a string, got {_describe(data)}')
    msg = String()
    msg.data = data
    return msg


def string_to_str(msg):
    return msg.data


LEVELS = {'OK': DiagnosticStatus.OK, 'WARN': DiagnosticStatus.WARN, 'ERROR': DiagnosticStatus.ERROR,
          'STALE': DiagnosticStatus.STALE}

_LEVEL_NAMES = {v: k for k, v in LEVELS.items()}


def event(t, level, name, message, values=None, source=''):
    """diagnostic_msgs/DiagnosticArray with one status: level 'OK' | 'WARN' | 'ERROR' ('STALE' also
    accepted), ``name`` the event kind (e.g. 'late_maneuver'), ``values`` a dict rendered to KeyValue
    strings, ``source`` (-> hardware_id) the emitting node's name.

    Values are text, so a non-finite number in ``values`` is allowed and written 'nan' / 'inf': an
    ERROR event is how a diverging estimate is reported."""
    return diagnostics(t, [(name, level, message, values)], source)


def diagnostics(t, statuses, source=''):
    """diagnostic_msgs/DiagnosticArray of several statuses, each (name, level, message, values) as ``event``'s
    (/diagnostics: each monitor's status, the ROS convention)."""
    msg = DiagnosticArray()
    _stamp_into(msg.header.stamp, t)
    msg.status = [_status(name, level, message, values, source) for name, level, message, values in statuses]
    return msg


def _status(name, level, message, values, source):
    if level not in LEVELS:
        raise ValueError(f'level: must be one of {list(LEVELS)}, got {level!r}')
    for field, text in (('name', name), ('message', message), ('source', source)):
        if type(text) is not str:
            raise ValueError(f'{field}: must be a string, got {_describe(text)}')
    status = DiagnosticStatus()
    status.level = LEVELS[level]
    status.name = name
    status.message = message
    status.hardware_id = source
    kvs = []
    for k, v in (values or {}).items():
        kv = KeyValue()
        kv.key = str(k)
        kv.value = value_text(v)
        kvs.append(kv)
    status.values = kvs
    return status


def events_from_msg(msg):
    """A DiagnosticArray -> list of {t, level, name, message, values (dict of str), source}."""
    t = stamp_to_sec(msg.header.stamp)
    out = []
    for s in msg.status:
        level = s.level if isinstance(s.level, bytes) else bytes([s.level])
        out.append({
            't': t,
            'level': _LEVEL_NAMES.get(level, f'LEVEL_{level[0]}'),
            'name': s.name,
            'message': s.message,
            'values': {kv.key: kv.value for kv in s.values},
            'source': s.hardware_id,
        })
    return out
