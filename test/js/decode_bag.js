#!/usr/bin/env node
// Reads a flyby bag's MCAP with Foxglove's own readers (@mcap/core, @foxglove/rosmsg,
// @foxglove/rosmsg2-serialization), as the Foxglove app does, and prints one JSON line:
// {"topics": {topic: {"messages": N, "nan": M}}, "tf_frames": ["parent->child", ...], "errors": [...]}
// "nan" counts the messages with a NaN anywhere in them (a sensor_msgs field left unused must be empty).
// Usage: node decode_bag.js BAG.mcap
'use strict';

const fs = require('fs');
const { McapStreamReader } = require('@mcap/core');
const { parse } = require('@foxglove/rosmsg');
const { MessageReader } = require('@foxglove/rosmsg2-serialization');

function hasNaN(value) {
  if (typeof value === 'number') return Number.isNaN(value);
  if (ArrayBuffer.isView(value)) return Array.prototype.some.call(value, Number.isNaN);
  if (Array.isArray(value)) return value.some(hasNaN);
  if (value && typeof value === 'object') return Object.values(value).some(hasNaN);
  return false;
}

function main(path) {
  const reader = new McapStreamReader({ validateCrcs: true });
  const schemas = new Map();
  const channels = new Map();
  const topics = {};
  const tfFrames = new Set();
  const errors = [];
  const onRecord = (record) => {
    if (record.type === 'Schema') {
      schemas.set(record.id, record);
    } else if (record.type === 'Channel') {
      const schema = schemas.get(record.schemaId);
      if (schema.encoding !== 'ros2msg' || record.messageEncoding !== 'cdr') {
        errors.push(`${record.topic}: schema ${schema.encoding} / ${record.messageEncoding}, not ros2msg / cdr`);
      }
      const definitions = parse(new TextDecoder().decode(schema.data), { ros2: true });
      channels.set(record.id, { topic: record.topic, type: schema.name, reader: new MessageReader(definitions) });
      topics[record.topic] = topics[record.topic] || { type: schema.name, messages: 0, nan: 0 };
    } else if (record.type === 'Message') {
      const channel = channels.get(record.channelId);
      const counts = topics[channel.topic];
      counts.messages += 1;
      let message;
      try {
        message = channel.reader.readMessage(record.data);
      } catch (err) {
        errors.push(`${channel.topic}: message ${counts.messages}: ${err.message}`);
        return;
      }
      const trailing = record.data.byteLength - channel.reader.lastReadByteLength();
      if (trailing > 3) {  // more than CDR's padding to 4 bytes: the schema does not match the payload
        errors.push(`${channel.topic}: message ${counts.messages}: ${trailing} bytes left after the message`);
      }
      if (hasNaN(message)) counts.nan += 1;
      if (channel.type === 'tf2_msgs/msg/TFMessage') {
        for (const t of message.transforms) tfFrames.add(`${t.header.frame_id}->${t.child_frame_id}`);
      }
    }
  };
  const fd = fs.openSync(path, 'r');
  const buffer = Buffer.alloc(1 << 22);
  for (;;) {
    const n = fs.readSync(fd, buffer, 0, buffer.length, null);
    if (n === 0) break;
    reader.append(new Uint8Array(buffer.buffer, buffer.byteOffset, n).slice());
    for (let record; (record = reader.nextRecord()) !== undefined;) onRecord(record);
  }
  fs.closeSync(fd);
  if (!reader.done()) errors.push(`${path}: the MCAP ends before its footer`);
  const out = { topics, tf_frames: [...tfFrames].sort(), errors: errors.slice(0, 20) };
  process.stdout.write(JSON.stringify(out) + '\n');
}

if (process.argv.length !== 3) {
  process.stderr.write('usage: node decode_bag.js BAG.mcap\n');
  process.exit(2);
}
main(process.argv[2]);
