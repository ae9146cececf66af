"""CRCs of a bag's MCAP file: written by ``BagWriter`` and the repair, verified before a bag is trusted.

rosbags 0.11.9 writes every CRC of an MCAP file as 0 ("not computed", https://mcap.dev/spec), so a
flipped byte goes unnoticed. ``write_crcs_with`` makes a rosbags ``Writer`` fill in the chunk CRCs
(CRC-32 of each chunk's uncompressed records, the field rosbags' own reader and mcap's
``validate_crcs`` check), then at close the data-section CRC of the DataEnd record (every byte from
the magic up to DataEnd) and the summary CRC of the footer. ``verify_mcap`` walks a file record by
record and checks every CRC that is not 0; the first mismatch raises ``BagError`` naming the chunk
or section, its byte range and the hint to run the repair.
"""

import struct
import zlib
from pathlib import Path

import zstandard

from flyby_msgs_py.bag.common import BagError

MAGIC = b'\x89MCAP0\r\n'
OP_FOOTER, OP_CHUNK, OP_DATA_END = 0x02, 0x06, 0x0F
_HEAD = struct.Struct('<BQ')          # record opcode, body length
_FOOTER_LEN = 9 + 8 + 8 + 4           # head, summary start, summary offset start, summary CRC
_CHUNK_CRC_AT = 9 + 24                # record offset of a chunk's uncompressed CRC
REPAIR_HINT = 'run `python -m flyby_msgs_py.bag repair DIR` to salvage what is intact'


def write_crcs_with(writer):
    """Make an opened rosbags ``Writer`` (MCAP storage) write chunk, data-section and summary CRCs.

    INTERNAL API of rosbags 0.11.9 (pinned in requirements.txt), as ``writer._force_pending_chunk_to_disk``:
    ``McapWriter.close_chunk()`` appends the pending chunk (``chunk.bio``) to the file ``bio`` with a
    CRC of 0, which is patched in place right after; ``McapWriter.close()`` closes the file, which is
    then reopened to patch DataEnd and the footer.
    """
    storage = writer.storage
    close_chunk, close = storage.close_chunk, storage.close

    def close_chunk_with_crc():
        crc = zlib.crc32(storage.chunk.bio.getbuffer())
        start = storage.bio.tell()
        close_chunk()
        end = storage.bio.tell()
        storage.bio.seek(start + _CHUNK_CRC_AT)
        storage.bio.write(struct.pack('<I', crc))
        storage.bio.seek(end)

    def close_with_crcs(*args, **kwargs):
        close(*args, **kwargs)
        _patch_section_crcs(storage.path)

    storage.close_chunk = close_chunk_with_crc
    storage.close = close_with_crcs


def _crc_of_range(f, start, end, crc=0):
    f.seek(start)
    while start < end:
        block = f.read(min(1 << 20, end - start))
        crc = zlib.crc32(block, crc)
        start += len(block)
    return crc


def _patch_section_crcs(path):
    """Fill in the data-section CRC (DataEnd) and the summary CRC (footer) of a closed MCAP file."""
    with Path(path).open('r+b') as f:
        size = f.seek(0, 2)
        footer_at = size - len(MAGIC) - _FOOTER_LEN
        f.seek(footer_at)
        op, _, summary_start, _ = struct.unpack('<BQQQ', f.read(25))
        data_end_at = summary_start - 13
        f.seek(data_end_at)
        if op != OP_FOOTER or f.read(1)[0] != OP_DATA_END:
            raise BagError(f'{path}: unexpected layout written by rosbags (no DataEnd before the summary)')
        data_crc = _crc_of_range(f, 0, data_end_at)
        summary_crc = _crc_of_range(f, summary_start, footer_at + 25)
        f.seek(data_end_at + 9)
        f.write(struct.pack('<I', data_crc))
        f.seek(footer_at + 25)
        f.write(struct.pack('<I', summary_crc))


def _chunk_records(body):
    """(stored CRC, uncompressed records) of a chunk record's body."""
    crc, = struct.unpack_from('<I', body, 24)
    n, = struct.unpack_from('<I', body, 28)
    compression = body[32:32 + n].decode('ascii', 'replace')
    length, = struct.unpack_from('<Q', body, 32 + n)
    records = body[40 + n:40 + n + length]
    if compression == 'zstd':
        size, = struct.unpack_from('<Q', body, 16)
        records = zstandard.ZstdDecompressor().decompress(records, max_output_size=size)
    elif compression:
        return 0, b''  # lz4 and others: not written by our writers, not checked
    return crc, records


def verify_mcap(path):
    """Check every non-zero CRC of a closed MCAP file; ``BagError`` (one line) at the first damage found.

    Returns the number of chunks whose CRC was checked (0 for a file written without CRCs).
    """
    path = Path(path)
    checked, k, summary_start = 0, 0, None
    with path.open('rb') as f:
        size = f.seek(0, 2)
        f.seek(0)
        if f.read(len(MAGIC)) != MAGIC:
            raise BagError(f'{path}: corrupted: no MCAP magic in its first 8 bytes; {REPAIR_HINT}')
        crc, pos = zlib.crc32(MAGIC), len(MAGIC)
        while True:
            head = f.read(_HEAD.size)
            if len(head) < _HEAD.size:
                raise BagError(f'{path}: cut off at byte {pos} of {size}: no footer (recorder killed?); {REPAIR_HINT}')
            op, length = _HEAD.unpack(head)
            if pos + _HEAD.size + length > size:
                raise BagError(f'{path}: corrupted record at byte {pos}: its length {length} runs past the end '
                               f'of the file ({size} bytes); {REPAIR_HINT}')
            body = f.read(length)
            if op == OP_DATA_END:
                stored, = struct.unpack_from('<I', body, 0) if length >= 4 else (0,)
                if stored and stored != crc:
                    raise BagError(f'{path}: corrupted outside the chunks in bytes 0..{pos}: data-section CRC '
                                   f'{crc:08x}, DataEnd says {stored:08x}; {REPAIR_HINT}')
                summary_start = pos + _HEAD.size + length
            elif op == OP_CHUNK:
                checked += _check_chunk(path, body, k, pos, pos + _HEAD.size + length)
                k += 1
            elif op == OP_FOOTER:
                _check_footer(path, f, body, pos, summary_start)
                return checked
            crc = zlib.crc32(body, zlib.crc32(head, crc))
            pos += _HEAD.size + length


def _check_chunk(path, body, k, start, end):
    """1 when chunk ``k`` (file bytes ``start..end``) has a CRC and it matches, 0 without CRC; else ``BagError``."""
    try:
        stored, records = _chunk_records(body)
    except (struct.error, zstandard.ZstdError) as err:
        raise BagError(f'{path}: chunk {k} (bytes {start}..{end}) is corrupted: {err}; {REPAIR_HINT}') from None
    if not stored:
        return 0
    actual = zlib.crc32(records)
    if actual != stored:
        raise BagError(f'{path}: chunk {k} (bytes {start}..{end}) is corrupted: CRC {actual:08x} of its records, '
                       f'the chunk says {stored:08x}; {REPAIR_HINT}')
    return 1


def _check_footer(path, f, body, pos, summary_start):
    """Summary CRC of the footer at file byte ``pos`` (the summary runs from ``summary_start``)."""
    if len(body) < 20:
        raise BagError(f'{path}: corrupted footer at byte {pos}; {REPAIR_HINT}')
    start, _, stored = struct.unpack_from('<QQI', body, 0)
    if f.read(len(MAGIC)) != MAGIC:
        raise BagError(f'{path}: corrupted: no MCAP magic after the footer at byte {pos}; {REPAIR_HINT}')
    if not stored:
        return
    if start != summary_start or _crc_of_range(f, start, pos + 25) != stored:
        raise BagError(f'{path}: corrupted summary (bytes {start}..{pos}): summary CRC mismatch; {REPAIR_HINT}')


def verify_bag(bag_dir):
    """``verify_mcap`` every MCAP file of a bag directory; returns the number of chunks checked."""
    return sum(verify_mcap(p) for p in sorted(Path(bag_dir).glob('*.mcap')) if p.is_file())
