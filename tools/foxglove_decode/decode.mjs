#!/usr/bin/env node
// Decodes every message of an MCAP file with Foxglove's own readers, as the Foxglove app
// does for a ROS 2 bag: @mcap/core (McapIndexedReader on the summary, then McapStreamReader
// front to back), chunks decompressed by @mcap/support's handlers, each channel's ros2msg
// schema parsed by @foxglove/rosmsg (ros2: true) and its CDR messages decoded by
// @foxglove/rosmsg2-serialization's MessageReader.
//
// Usage: node decode.mjs FILE.mcap [--first N] [--exact-length]
// Prints a JSON summary on stdout: per topic the schema, the messages decoded by each
// reader, the count of the summary's Statistics record, the most bytes a message left
// undecoded and, for sensor_msgs/msg/JointState topics, the first N decoded messages
// (default 3; times in ns and 64-bit integers as decimal strings). Exits 1 on any failure
// (listed under "errors" and on stderr): a schema that does not parse, a message that does
// not decode, a count that differs from the Statistics record or between the two readers,
// a missing summary or footer; with --exact-length also a message that leaves more than
// CDR's alignment padding (3 bytes) undecoded. Foxglove ignores such trailing bytes, as
// CDR allows, and rclpy's serialize_message leaves some (its buffer is the estimated
// size), but what a DDS reader receives is the message's own length: in a recorded bag
// trailing bytes mean the data and the schema disagree. Exits 2 on bad usage.

import { createReadStream } from "node:fs";
import { open } from "node:fs/promises";

import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { FileHandleReadable } from "@mcap/nodejs";
import { loadDecompressHandlers } from "@mcap/support";

const JOINT_STATE = "sensor_msgs/msg/JointState";
const MAX_PADDING = 3; // CDR pads a message to 4-byte alignment at most
const MAX_ERRORS = 50;

function usage(message) {
  const synopsis = "node decode.mjs FILE.mcap [--first N] [--exact-length]";
  process.stderr.write(`${message}\nusage: ${synopsis}\n`);
  process.exit(2);
}

function parseArgs(argv) {
  let file;
  let first = 3;
  let exactLength = false;
  for (let i = 0; i < argv.length; i++) {
    if (argv[i] === "--exact-length") {
      exactLength = true;
    } else if (argv[i] === "--first") {
      first = Number(argv[++i]);
      if (!Number.isInteger(first) || first < 0) usage("--first takes an integer >= 0");
    } else if (argv[i].startsWith("-")) {
      usage(`unknown option ${argv[i]}`);
    } else if (file === undefined) {
      file = argv[i];
    } else {
      usage("one file only");
    }
  }
  if (file === undefined) usage("no file given");
  return { file, first, exactLength };
}

// A decoded value as JSON: typed arrays as lists, 64-bit integers (bigints) as decimal
// strings, non-finite floats as the strings "NaN", "Infinity", "-Infinity".
function plain(value) {
  if (typeof value === "bigint") return value.toString();
  if (typeof value === "number") return Number.isFinite(value) ? value : String(value);
  if (ArrayBuffer.isView(value)) return Array.from(value, plain);
  if (Array.isArray(value)) return value.map(plain);
  if (value !== null && typeof value === "object") {
    return Object.fromEntries(Object.entries(value).map(([k, v]) => [k, plain(v)]));
  }
  return value;
}

class Decoders {
  constructor(errors, exactLength) {
    this.errors = errors;
    this.exactLength = exactLength;
    this.byChannel = new Map(); // channel id -> { reader, topic } (reader null: no schema)
  }

  fail(text) {
    if (this.errors.length < MAX_ERRORS) this.errors.push(text);
    else if (this.errors.length === MAX_ERRORS) this.errors.push("... further errors left out");
  }

  // The MessageReader of a channel, as Foxglove builds it (parseChannel for cdr + ros2msg).
  add(channel, schema) {
    if (this.byChannel.has(channel.id)) return;
    let reader = null;
    if (channel.messageEncoding !== "cdr") {
      this.fail(`${channel.topic}: message encoding ${channel.messageEncoding}, not cdr`);
    } else if (schema === undefined) {
      this.fail(`${channel.topic}: schema ${channel.schemaId} not found`);
    } else if (schema.encoding !== "ros2msg") {
      this.fail(`${channel.topic}: schema encoding ${schema.encoding}, not ros2msg`);
    } else {
      try {
        const text = new TextDecoder().decode(schema.data);
        reader = new MessageReader(parse(text, { ros2: true }));
      } catch (err) {
        this.fail(`${channel.topic}: schema ${schema.name} does not parse: ${err}`);
      }
    }
    this.byChannel.set(channel.id, { reader, topic: channel.topic });
  }

  // { decoded, left } (left: bytes left undecoded), or undefined (the failure recorded).
  decode(message, where) {
    const entry = this.byChannel.get(message.channelId);
    if (entry === undefined) {
      this.fail(`${where}: message on unknown channel ${message.channelId}`);
      return undefined;
    }
    const at = `${where}: ${entry.topic} message at log time ${message.logTime}`;
    if (entry.reader === null) {
      this.fail(`${at}: no usable schema`);
      return undefined;
    }
    try {
      const decoded = entry.reader.readMessage(message.data);
      const left = message.data.byteLength - entry.reader.lastReadByteLength();
      if (this.exactLength && left > MAX_PADDING) {
        this.fail(`${at}: ${left} bytes left undecoded (schema and data disagree)`);
        return undefined;
      }
      return { decoded, left };
    } catch (err) {
      this.fail(`${at}: does not decode: ${err}`);
      return undefined;
    }
  }
}

function topicEntry(topics, channel, schema) {
  if (!topics.has(channel.topic)) {
    topics.set(channel.topic, {
      schema: schema?.name ?? null,
      schema_encoding: schema?.encoding ?? null,
      message_encoding: channel.messageEncoding,
      channels: [],
      decoded: 0,
      statistics_count: 0,
      stream_decoded: 0,
      max_bytes_left: 0,
      first: [],
    });
  }
  const entry = topics.get(channel.topic);
  if (!entry.channels.includes(channel.id)) entry.channels.push(channel.id);
  return entry;
}

function sample(message, decoded) {
  const stamp = decoded.header?.stamp;
  return {
    log_time_ns: message.logTime.toString(),
    stamp_ns:
      stamp === undefined
        ? null
        : (BigInt(stamp.sec) * 1_000_000_000n + BigInt(stamp.nanosec)).toString(),
    frame_id: decoded.header?.frame_id ?? null,
    name: plain(decoded.name),
    position: plain(decoded.position),
    velocity: plain(decoded.velocity),
    effort: plain(decoded.effort),
  };
}

// The indexed pass: what Foxglove does with a file that has a summary.
async function indexedPass(file, decompressHandlers, options, topics, errors) {
  const handle = await open(file, "r");
  try {
    const reader = await McapIndexedReader.Initialize({
      readable: new FileHandleReadable(handle),
      decompressHandlers,
    });
    const decoders = new Decoders(errors, options.exactLength);
    for (const channel of reader.channelsById.values()) {
      const schema = reader.schemasById.get(channel.schemaId);
      topicEntry(topics, channel, schema);
      decoders.add(channel, schema);
    }
    const stats = reader.statistics;
    if (stats === undefined) {
      errors.push("the summary has no Statistics record");
    } else {
      for (const [id, count] of stats.channelMessageCounts) {
        const channel = reader.channelsById.get(id);
        if (channel === undefined) errors.push(`Statistics counts unknown channel ${id}`);
        else topics.get(channel.topic).statistics_count += Number(count);
      }
    }
    let total = 0;
    for await (const message of reader.readMessages({ validateCrcs: true })) {
      total += 1;
      const result = decoders.decode(message, "indexed reader");
      if (result === undefined) continue;
      const channel = reader.channelsById.get(message.channelId);
      const entry = topics.get(channel.topic);
      entry.decoded += 1;
      entry.max_bytes_left = Math.max(entry.max_bytes_left, result.left);
      if (entry.schema === JOINT_STATE && entry.first.length < options.first) {
        entry.first.push(sample(message, result.decoded));
      }
    }
    const chunkCompression = [...new Set(reader.chunkIndexes.map((c) => c.compression))].sort();
    return {
      library: reader.header.library,
      profile: reader.header.profile,
      chunks: reader.chunkIndexes.length,
      chunk_compression: chunkCompression,
      messages_read: total,
      statistics_message_count: stats === undefined ? null : Number(stats.messageCount),
    };
  } finally {
    await handle.close();
  }
}

// The streaming pass: what Foxglove does with a file read front to back (no summary used).
async function streamPass(file, decompressHandlers, options, topics, errors) {
  const stream = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  const decoders = new Decoders(errors, options.exactLength);
  const schemas = new Map();
  const channels = new Map();
  let total = 0;
  for await (const data of createReadStream(file)) {
    stream.append(data);
    for (let record; (record = stream.nextRecord()); ) {
      if (record.type === "Schema") {
        schemas.set(record.id, record);
      } else if (record.type === "Channel") {
        channels.set(record.id, record);
        topicEntry(topics, record, schemas.get(record.schemaId));
        decoders.add(record, schemas.get(record.schemaId));
      } else if (record.type === "Message") {
        total += 1;
        if (decoders.decode(record, "stream reader") !== undefined) {
          topics.get(channels.get(record.channelId).topic).stream_decoded += 1;
        }
      }
    }
  }
  if (!stream.done()) errors.push("stream reader: the file ends before its footer");
  return total;
}

async function main() {
  const options = parseArgs(process.argv.slice(2));
  const { file } = options;
  const errors = [];
  const topics = new Map();
  const decompressHandlers = await loadDecompressHandlers();
  let summary = {};
  try {
    summary = await indexedPass(file, decompressHandlers, options, topics, errors);
    summary.stream_messages_read = await streamPass(
      file,
      decompressHandlers,
      options,
      topics,
      errors,
    );
  } catch (err) {
    errors.push(`reading ${file}: ${err}`);
  }
  let decoded = 0;
  for (const [topic, entry] of topics) {
    decoded += entry.decoded;
    if (entry.decoded !== entry.statistics_count) {
      errors.push(
        `${topic}: ${entry.decoded} messages decoded, the Statistics record counts ${entry.statistics_count}`,
      );
    }
    if (entry.stream_decoded !== entry.decoded) {
      errors.push(
        `${topic}: ${entry.stream_decoded} messages decoded streaming, ${entry.decoded} indexed`,
      );
    }
  }
  if (summary.statistics_message_count != null && decoded !== summary.statistics_message_count) {
    errors.push(
      `${decoded} messages decoded, the Statistics record counts ${summary.statistics_message_count}`,
    );
  }
  const out = {
    file,
    exact_length: options.exactLength,
    ...summary,
    messages_decoded: decoded,
    topics: Object.fromEntries([...topics].sort(([a], [b]) => (a < b ? -1 : a > b ? 1 : 0))),
    errors,
  };
  process.stdout.write(`${JSON.stringify(out, null, 2)}\n`);
  for (const error of errors) process.stderr.write(`foxglove_decode: ${error}\n`);
  process.exitCode = errors.length ? 1 : 0;
}

await main();
