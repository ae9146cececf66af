"""The serialized form (CDR, little endian, as rmw_fastrtps sends it and rosbags stores it): headers, strings and
doubles.

A publisher takes these bytes (rclpy Publisher.publish(bytes)) and a raw=True subscription hands them over, which
spares the Python message objects: on this machine ~25 us to build and serialize an Odometry message and
~85 us to deserialize and read one, against ~5 us each way here.
"""

import struct

import numpy as np

from flyby_msgs_py.convert.fields import _frame
from flyby_msgs_py.convert.stamps import NS_PER_S, _stamp_parts

_CDR_LE = b'\x00\x01\x00\x00'


def _cdr_string(text, offset):
    """CDR of a string field starting at ``offset`` bytes into the payload: padding to 4, length with the NUL,
    the UTF-8 bytes and the NUL."""
    data = text.encode()
    return b'\0' * (-offset % 4) + struct.pack('<I', len(data) + 1) + data + b'\0'


def _cdr_string_at(data, offset, field):
    """(text, offset after it) of the CDR string at ``offset`` of the payload (``data`` includes the 4-byte
    encapsulation header)."""
    offset += -offset % 4
    (size,) = struct.unpack_from('<I', data, 4 + offset)
    start = 4 + offset + 4
    if size < 1 or start + size > len(data):
        raise ValueError(f'{field}: malformed CDR string (length {size} at byte {start - 4})')
    return data[start:start + size - 1].decode(), offset + 4 + size


def _cdr_stamp_ns(data, typename):
    """The time [ns] of the Time that opens the payload of serialized ``data`` (a Clock's or a Header's stamp);
    ValueError for anything but little-endian CDR that long."""
    if len(data) < 12 or bytes(data[:2]) != _CDR_LE[:2]:
        raise ValueError(f'{typename}: expected little-endian CDR (encapsulation 00 01) of at least 12 bytes, got '
                         f'{bytes(data[:12]).hex()}')
    sec, nanosec = struct.unpack_from('<iI', data, 4)
    return sec * NS_PER_S + nanosec


def _cdr_header(data, typename):
    """(stamp [ns], frame_id, payload offset just after them) of the std_msgs/Header that opens ``data``."""
    ns = _cdr_stamp_ns(data, typename)
    frame_id, offset = _cdr_string_at(data, 8, 'frame_id')
    return ns, frame_id, offset


def clock_cdr_to_ns(data):
    """The time [ns] of a serialized rosgraph_msgs/Clock (a raw=True subscription's bytes)."""
    return _cdr_stamp_ns(data, 'Clock')


def _pad8(payload):
    """``payload`` padded to the 8-byte alignment of the float64 field that follows."""
    return payload + b'\0' * (-len(payload) % 8)


def _header_cdr(t, frame_id):
    """CDR payload of a std_msgs/Header (stamp t [s], frame_id), unpadded."""
    head = struct.pack('<iI', *_stamp_parts(t))
    return head + _cdr_string(_frame(frame_id), len(head))


def _header_from_cdr(data, typename):
    """(t [s], frame_id, payload offset after the header padded to 8) of serialized ``data``."""
    ns, frame_id, offset = _cdr_header(data, typename)
    return ns / 1e9, frame_id, offset + (-offset % 8)


def _doubles_from_cdr(data, offset, n, typename):
    if 4 + offset + 8 * n != len(data):
        raise ValueError(f'{typename}: {len(data)} bytes of CDR, expected {4 + offset + 8 * n}')
    return np.frombuffer(data, '<f8', n, 4 + offset).astype(float)


def header_cdr_to_ns(data):
    """(time [ns], frame_id) of a serialized std_msgs/Header (e.g. a node's progress)."""
    return _cdr_header(data, 'Header')[:2]


def _stamped_cdr(t, frame_id, values):
    return b''.join((_CDR_LE, _pad8(_header_cdr(t, frame_id)), struct.pack(f'<{len(values)}d', *values)))


def _stamped_from_cdr(data, n, typename):
    t, _frame_id, offset = _header_from_cdr(data, typename)
    return t, _doubles_from_cdr(data, offset, n, typename)
