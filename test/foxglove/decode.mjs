// Decode an MCAP recording with the readers Foxglove uses, and print what they decode as JSON.
//
//   node decode.mjs RECORDING.mcap
//
// The file is read with @mcap/core (McapIndexedReader through its summary and index, as Foxglove
// opens a local file; McapStreamReader record by record when there is no usable summary, as
// Foxglove falls back to for a cut file), chunks decompressed by @mcap/support's handlers. Each
// schema is parsed with @foxglove/rosmsg (parse(text, { ros2: true })) and each message decoded
// with @foxglove/rosmsg2-serialization's MessageReader, exactly as Foxglove's ROS 2 support does.
// A schema that does not parse or a message that does not decode is counted and reported; the
// script never stops at the first one.
//
// Output (stdout, one JSON object): profile, library, reader ("indexed" or "stream"), complete
// (a summary was read / the stream reached its footer), cut (why reading stopped early, or null),
// statisticsMessageCount (from the summary, or null), channels (topic, schema name and encoding,
// message encoding, metadata), schemaErrors ({schema name: error}), messageCount, decodedCount,
// failures (the first 20 errors), messages ([topic, logTime, publishTime, decoded]: bigints as
// strings, typed arrays as arrays, uint8 arrays as { base64 }).
// Exit code 0 when the file could be opened at all, 2 on a usage error.

import { open } from "node:fs/promises";

import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import { McapIndexedReader, McapStreamReader } from "@mcap/core";
import { loadDecompressHandlers } from "@mcap/support";

const path = process.argv[2];
if (!path || process.argv.length !== 3) {
  process.stderr.write("usage: node decode.mjs RECORDING.mcap\n");
  process.exit(2);
}

const decompressHandlers = await loadDecompressHandlers();
const result = {
  path,
  profile: null,
  library: null,
  reader: null,
  complete: false,
  cut: null,
  statisticsMessageCount: null,
  channels: [],
  schemaErrors: {},
  messageCount: 0,
  decodedCount: 0,
  failures: [],
  messages: [],
};

const schemas = new Map(); // schema id -> { name, encoding, reader | error }
const channels = new Map(); // channel id -> { topic, schemaId, messageEncoding, metadata }

function addSchema(schema) {
  if (schemas.has(schema.id)) return;
  const text = new TextDecoder().decode(schema.data);
  const entry = { name: schema.name, encoding: schema.encoding };
  try {
    if (schema.encoding !== "ros2msg") throw new Error(`schema encoding ${schema.encoding}, expected ros2msg`);
    entry.reader = new MessageReader(parse(text, { ros2: true }));
  } catch (error) {
    entry.error = String(error?.message ?? error);
    result.schemaErrors[schema.name] = entry.error;
  }
  schemas.set(schema.id, entry);
}

function addChannel(channel) {
  if (channels.has(channel.id)) return;
  const metadata = Object.fromEntries(channel.metadata);
  channels.set(channel.id, { topic: channel.topic, schemaId: channel.schemaId, messageEncoding: channel.messageEncoding });
  const schema = schemas.get(channel.schemaId);
  result.channels.push({
    id: channel.id,
    topic: channel.topic,
    schemaName: schema?.name ?? null,
    schemaEncoding: schema?.encoding ?? null,
    messageEncoding: channel.messageEncoding,
    metadata,
  });
}

function plain(value) {
  if (typeof value === "bigint") return value.toString();
  if (value instanceof Uint8Array) return { base64: Buffer.from(value.buffer, value.byteOffset, value.byteLength).toString("base64") };
  if (ArrayBuffer.isView(value)) return Array.from(value, plain);
  if (Array.isArray(value)) return value.map(plain);
  if (value !== null && typeof value === "object") {
    return Object.fromEntries(Object.entries(value).map(([k, v]) => [k, plain(v)]));
  }
  return value;
}

function addMessage(message) {
  result.messageCount += 1;
  const channel = channels.get(message.channelId);
  const fail = (why) => {
    if (result.failures.length < 20) result.failures.push(`${channel?.topic ?? message.channelId}: ${why}`);
  };
  if (!channel) return fail("message on an unknown channel");
  if (channel.messageEncoding !== "cdr") return fail(`message encoding ${channel.messageEncoding}, expected cdr`);
  const schema = schemas.get(channel.schemaId);
  if (!schema) return fail("channel with an unknown schema");
  if (!schema.reader) return fail(`schema ${schema.name} does not parse: ${schema.error}`);
  let decoded;
  try {
    decoded = schema.reader.readMessage(message.data);
  } catch (error) {
    return fail(`does not decode as ${schema.name}: ${error?.message ?? error}`);
  }
  result.decodedCount += 1;
  result.messages.push([channel.topic, message.logTime.toString(), message.publishTime.toString(), plain(decoded)]);
}

const handle = await open(path, "r");
const size = BigInt((await handle.stat()).size);
const readable = {
  size: async () => size,
  read: async (offset, length) => {
    const buffer = new Uint8Array(Number(length));
    const { bytesRead } = await handle.read(buffer, 0, buffer.length, Number(offset));
    if (bytesRead !== buffer.length) throw new Error(`short read at ${offset}`);
    return buffer;
  },
};

let indexed = null;
try {
  indexed = await McapIndexedReader.Initialize({ readable, decompressHandlers });
} catch (error) {
  result.cut = `no usable summary: ${error?.message ?? error}`;
}

if (indexed) {
  result.reader = "indexed";
  result.profile = indexed.header.profile;
  result.library = indexed.header.library;
  result.statisticsMessageCount = indexed.statistics ? Number(indexed.statistics.messageCount) : null;
  for (const schema of indexed.schemasById.values()) addSchema(schema);
  for (const channel of indexed.channelsById.values()) addChannel(channel);
  try {
    for await (const message of indexed.readMessages()) addMessage(message);
    result.complete = true;
  } catch (error) {
    result.cut = `indexed reading failed: ${error?.message ?? error}`;
  }
} else {
  result.reader = "stream";
  const stream = new McapStreamReader({ decompressHandlers });
  const data = new Uint8Array(Number(size));
  await handle.read(data, 0, data.length, 0);
  stream.append(data);
  try {
    for (let record; (record = stream.nextRecord()); ) {
      switch (record.type) {
        case "Header":
          result.profile = record.profile;
          result.library = record.library;
          break;
        case "Schema":
          addSchema(record);
          break;
        case "Channel":
          addChannel(record);
          break;
        case "Message":
          addMessage(record);
          break;
        case "Statistics":
          result.statisticsMessageCount = Number(record.messageCount);
          break;
        default:
          break;
      }
    }
    result.complete = stream.done();
    if (!result.complete) result.cut = `the file ends inside a record (${stream.bytesRemaining()} bytes left unparsed)`;
  } catch (error) {
    result.cut = `stream reading stopped: ${error?.message ?? error}`;
  }
}
await handle.close();
process.stdout.write(JSON.stringify(result));
process.stdout.write("\n");
