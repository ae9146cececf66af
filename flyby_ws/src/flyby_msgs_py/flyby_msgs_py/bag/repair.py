"""Repair of a bag whose recorder died: salvage every complete MCAP record into a valid bag.

A recorder killed with SIGKILL leaves an MCAP file with no summary, no footer and maybe a
half-written last record, and no ``metadata.yaml``. ``salvage_mcap`` reads such a file with the
``mcap`` package's ``StreamReader`` (https://mcap.dev/spec), which reads records in file order and
raises at the first one that is cut off; ``repair_bag`` copies what it salvaged into a fresh bag.
"""

import os
import shutil
import struct
from pathlib import Path
from typing import NamedTuple

import zstandard
from mcap.exceptions import EndOfFile, McapError, RecordLengthLimitExceeded
from mcap.records import Channel, Chunk, DataEnd, Footer, Message, Schema
from mcap.stream_reader import StreamReader, breakup_chunk
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.rosbag2.metadata import parse_qos
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from flyby_msgs_py.bag.common import BagError, jazzy_typestore
from flyby_msgs_py.bag.integrity import REPAIR_HINT, verify_bag, write_crcs_with
from flyby_msgs_py.bag.reader import bag_time_range, bag_topics

MCAP_MAGIC = b'\x89MCAP0\r\n'
DAMAGED_SUFFIX = '.damaged'
_REPAIR_TMP = '.repair-tmp'

# What StreamReader raises at a cut-off record: EndOfFile when a read finds no byte left,
# struct.error when a fixed-size field is cut short, RecordLengthLimitExceeded for a length beyond
# the file (the limit is the file size).
_CUT_OFF = (EndOfFile, struct.error, RecordLengthLimitExceeded)
# ... and at a complete but bad one: McapError (unknown compression), ValueError (chunk CRC
# mismatch, string not UTF-8), RuntimeError (lz4 data), ZstdError (zstd data).
_BAD_RECORD = (McapError, ValueError, RuntimeError, zstandard.ZstdError)


class _Salvage(NamedTuple):
    schemas: dict        # schema id -> (name, encoding, data str)
    channels: dict       # channel id -> (schema id, topic, message encoding, metadata dict)
    messages: list       # (channel id, log time ns, data bytes)
    complete_until: int  # file offset just after the last complete record
    stop_reason: str


def salvage_mcap(mcap_path):
    """Every complete record of a (possibly cut-off) MCAP file: schemas, channels, messages.

    Records are read in file order up to the data end record, the end of the file or the first
    record that is cut off or bad, whichever comes first. ``StreamReader`` hands out each chunk whole;
    its records are taken only if its CRC (when the writer set one) matches: a corrupted chunk is
    skipped (named in the stop reason) and the salvage goes on after it, and a cut-off chunk gives
    nothing. Records of unknown opcode are skipped, as the MCAP spec asks.
    """
    path = Path(mcap_path)
    out = _Salvage({}, {}, [], 0, '')
    skipped = []
    with path.open('rb') as f:
        if f.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
            return out._replace(stop_reason='no MCAP magic')
        complete_until, stop_reason = f.tell(), 'end of file'
        # A record longer than the whole file is cut off: the limit stops it before a huge read.
        reader = StreamReader(f, skip_magic=True, validate_crcs=True, emit_chunks=True,
                              record_size_limit=os.fstat(f.fileno()).st_size)
        try:
            for record in reader.records:
                # A record is yielded once read whole: the file position is just after it.
                start, complete_until = complete_until, f.tell()
                if isinstance(record, Chunk):
                    try:
                        records = breakup_chunk(record, validate_crc=True)
                    except _BAD_RECORD as err:
                        skipped.append(f'bytes {start}..{complete_until} ({type(err).__name__})')
                        continue
                else:
                    records = [record]
                if _take(out, records):
                    stop_reason = 'end of data section'
                    break
        except _CUT_OFF:
            stop_reason = f'record after byte {complete_until} cut off'
        except _BAD_RECORD as err:
            stop_reason = f'bad record after byte {complete_until}: {type(err).__name__}: {err}'
    if skipped:
        stop_reason += f'; {len(skipped)} corrupted chunk(s) skipped: {", ".join(skipped)}'
    return out._replace(complete_until=complete_until, stop_reason=stop_reason)


def _take(out, records):
    """Add schemas, channels and messages of ``records`` to the salvage ``out``; True at the end of the data."""
    for record in records:
        if isinstance(record, Schema):
            out.schemas[record.id] = (record.name, record.encoding, record.data.decode())
        elif isinstance(record, Channel):
            out.channels[record.id] = (record.schema_id, record.topic, record.message_encoding, record.metadata)
        elif isinstance(record, Message):
            out.messages.append((record.channel_id, record.log_time, record.data))
        elif isinstance(record, (DataEnd, Footer)):
            return True
    return False


def _mcap_files(bag_dir):
    return sorted(p for p in bag_dir.glob('*.mcap') if p.is_file())


def _damage(bag_dir):
    """Why the bag needs a repair (one line), or None when it opens and every CRC matches."""
    if not (bag_dir / 'metadata.yaml').is_file():
        return 'no metadata.yaml'
    try:
        verify_bag(bag_dir)
    except BagError as err:
        return str(err).removesuffix('; ' + REPAIR_HINT)
    try:
        with AnyReader([bag_dir], default_typestore=jazzy_typestore()):
            return None
    except Exception as err:  # noqa: BLE001 - any failure to open means "needs repair"
        return f'rosbags cannot open it: {err}'


def _rihs01(schema_name, encoding, text):
    """Type hash of a schema, computed the way ``AnyReader`` checks it."""
    if encoding == 'ros2msg':
        store = get_typestore(Stores.EMPTY)
        store.register(get_types_from_msg(text, schema_name))
        return store.hash_rihs01(schema_name)
    return jazzy_typestore().hash_rihs01(schema_name)


def repair_bag(bag_dir):
    """Rebuild a bag whose recorder died: salvage every complete record into a valid bag.

    A bag that opens (``metadata.yaml`` present, MCAP readable, every CRC matching) is left alone. Otherwise the MCAP
    (or a ``*.mcap.damaged`` left by an interrupted repair) is read by ``salvage_mcap`` up to the
    first cut-off record; complete chunks give schemas, channels and messages, which are copied as raw
    bytes into a fresh bag built in a temporary directory. Then the damaged file is renamed to
    ``*.mcap.damaged``, the new MCAP moved in and ``metadata.yaml`` written last.

    A file that holds no complete message raises ``BagError`` and is left unchanged.

    Returns a JSON-able report: ``status`` ('valid' or 'repaired'), ``repaired``, ``messages``
    (topic -> count), ``message_count``, ``first_timestamp_ns``, ``last_timestamp_ns`` and, when
    repaired, ``damaged_file``, ``bytes_total``, ``bytes_salvaged``, ``stop_reason``,
    ``orphan_messages`` (messages of an unknown channel, dropped), ``damage`` (why it was repaired).
    """
    bag_dir = Path(bag_dir)
    if not bag_dir.is_dir():
        raise BagError(f'{bag_dir}: no such bag directory')
    damage = _damage(bag_dir)
    if damage is None:
        return _valid_report(bag_dir)
    source, damaged = _repair_source(bag_dir)
    found = salvage_mcap(source)
    if not found.messages:
        # Nothing to gain: the bag is left as it is (an empty bag would pass for a valid one).
        raise BagError(f'{source}: nothing to salvage, no complete message in {source.stat().st_size} bytes '
                       f'({found.stop_reason}); bag left unchanged')
    tmp_root = bag_dir / _REPAIR_TMP
    if tmp_root.exists():
        shutil.rmtree(tmp_root)
    tmp_root.mkdir()
    new_bag = tmp_root / bag_dir.name
    try:
        counts, orphans, first, last = _write_salvaged(found, new_bag)
        new_mcap = new_bag / f'{new_bag.name}.mcap'
        if source != damaged:
            source.rename(damaged)
        final_mcap = _free_name(bag_dir / new_mcap.name)
        if final_mcap.name != new_mcap.name:
            raise BagError(f'{bag_dir}: {new_mcap.name} exists and is not the damaged file')
        new_mcap.rename(final_mcap)
        (new_bag / 'metadata.yaml').rename(bag_dir / 'metadata.yaml')
    finally:
        shutil.rmtree(tmp_root, ignore_errors=True)
    return {'bag_dir': str(bag_dir), 'status': 'repaired', 'repaired': True,
            'messages': counts, 'message_count': sum(counts.values()),
            'first_timestamp_ns': first, 'last_timestamp_ns': last,
            'damaged_file': str(damaged), 'bytes_total': damaged.stat().st_size,
            'bytes_salvaged': found.complete_until, 'stop_reason': found.stop_reason,
            'orphan_messages': orphans, 'damage': damage}


def _valid_report(bag_dir):
    """The report of a bag that opens (left alone)."""
    topics = bag_topics(bag_dir)
    start, end = bag_time_range(bag_dir) or (None, None)
    return {'bag_dir': str(bag_dir), 'status': 'valid', 'repaired': False,
            'messages': {t: n for t, (_, n) in topics.items()},
            'message_count': sum(n for _, n in topics.values()),
            'first_timestamp_ns': start, 'last_timestamp_ns': end}


def _repair_source(bag_dir):
    """(the MCAP to salvage, the name the damaged file keeps): the bag's one MCAP, or the ``*.mcap.damaged`` an
    interrupted repair left."""
    mcaps = _mcap_files(bag_dir)
    if len(mcaps) > 1:
        raise BagError(f'{bag_dir}: {len(mcaps)} MCAP files, repair handles one: '
                       f'{", ".join(p.name for p in mcaps)}')
    if mcaps:
        source = mcaps[0]
        return source, _free_name(source.with_name(source.name + DAMAGED_SUFFIX))
    leftovers = sorted(bag_dir.glob('*.mcap' + DAMAGED_SUFFIX + '*'))
    if not leftovers:
        raise BagError(f'{bag_dir}: no MCAP file to repair')
    return leftovers[-1], leftovers[-1]


def _write_salvaged(found, new_bag):
    """Write what ``salvage_mcap`` found into a fresh bag at ``new_bag`` (raw bytes); returns (messages per topic,
    orphan messages, first and last log time [ns])."""
    counts, orphans, first, last = {}, 0, None, None
    writer = Writer(new_bag, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    write_crcs_with(writer)
    connections = {}
    for cid, (sid, topic, encoding, metadata) in sorted(found.channels.items()):
        schema = found.schemas.get(sid)
        if schema is None:
            continue
        name, schema_encoding, text = schema
        connections[cid] = writer.add_connection(
            topic, name, msgdef=text, rihs01=_rihs01(name, schema_encoding, text),
            serialization_format=encoding,
            offered_qos_profiles=parse_qos(metadata.get('offered_qos_profiles', '')))
        counts.setdefault(topic, 0)
    for cid, log_time, data in found.messages:
        connection = connections.get(cid)
        if connection is None:
            orphans += 1
            continue
        writer.write(connection, log_time, data)
        counts[connection.topic] += 1
        first = log_time if first is None else min(first, log_time)
        last = log_time if last is None else max(last, log_time)
    writer.close()
    return counts, orphans, first, last

def _free_name(path):
    """``path`` if free, else ``path.1``, ``path.2`` ..."""
    candidate, n = path, 0
    while candidate.exists():
        n += 1
        candidate = path.with_name(f'{path.name}.{n}')
    return candidate
