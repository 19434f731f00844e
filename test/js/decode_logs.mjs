// Decode every message of MCAP files as Foxglove does: @mcap/core's indexed reader
// (summary, chunk indexes, CRCs), @mcap/support's decompression, the ros2msg schema
// parsed by @foxglove/rosmsg and the CDR decoded by @foxglove/rosmsg2-serialization.
//
//   node decode_logs.mjs OUT.json FILE.mcap...
//
// OUT.json: {FILE: {"error": text} or {"schema_errors": [{topic, error}], "messages":
// [{topic, log_time, size, decoded, left_over, value} or {topic, log_time, size, error}]}},
// messages in log-time order; every channel's schema is parsed, also without messages.
// `decoded` is the offset where the decoder stopped (header included); `left_over` the
// first (up to 16) bytes after it. Values as JSON: typed arrays as arrays; 64-bit
// integers as numbers when exact, else {"int": text}; non-finite floats as
// {"float": "NaN" | "Infinity" | "-Infinity"}.

import { open, writeFile } from "node:fs/promises";

import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg2-serialization";
import { McapIndexedReader } from "@mcap/core";
import { loadDecompressHandlers } from "@mcap/support";

class FileReadable {
  constructor(handle, size) {
    this.handle = handle;
    this.fileSize = size;
  }

  async size() {
    return BigInt(this.fileSize);
  }

  async read(offset, length) {
    const buffer = new Uint8Array(Number(length));
    const { bytesRead } = await this.handle.read(buffer, 0, buffer.length, Number(offset));
    if (bytesRead !== buffer.length) {
      throw new Error(`short read at ${offset}: ${bytesRead} of ${length} bytes`);
    }
    return buffer;
  }
}

function plain(value) {
  if (typeof value === "bigint") {
    return Number.isSafeInteger(Number(value)) ? Number(value) : { int: value.toString() };
  }
  if (typeof value === "number" && !Number.isFinite(value)) {
    return { float: String(value) };
  }
  if (ArrayBuffer.isView(value)) {
    return Array.from(value, plain);
  }
  if (Array.isArray(value)) {
    return value.map(plain);
  }
  if (value !== null && typeof value === "object") {
    return Object.fromEntries(Object.entries(value).map(([key, item]) => [key, plain(item)]));
  }
  return value;
}

function messageReader(schema) {
  if (schema.encoding !== "ros2msg") {
    throw new Error(`schema ${schema.name}: encoding ${schema.encoding}, not ros2msg`);
  }
  const text = new TextDecoder().decode(schema.data);
  return new MessageReader(parse(text, { ros2: true }));
}

async function decodeFile(path, decompressHandlers) {
  const handle = await open(path, "r");
  try {
    const { size } = await handle.stat();
    const reader = await McapIndexedReader.Initialize({
      readable: new FileReadable(handle, size),
      decompressHandlers,
    });
    const readers = new Map();
    const schemaErrors = [];
    for (const channel of reader.channelsById.values()) {
      try {
        if (channel.messageEncoding !== "cdr") {
          throw new Error(`message encoding ${channel.messageEncoding}, not cdr`);
        }
        if (!readers.has(channel.schemaId)) {
          readers.set(channel.schemaId, messageReader(reader.schemasById.get(channel.schemaId)));
        }
      } catch (error) {
        schemaErrors.push({ topic: channel.topic, error: String(error) });
      }
    }
    const messages = [];
    for await (const message of reader.readMessages()) {
      const channel = reader.channelsById.get(message.channelId);
      const base = {
        topic: channel.topic,
        log_time: message.logTime.toString(),
        size: message.data.byteLength,
      };
      try {
        const decoder = readers.get(channel.schemaId);
        if (decoder === undefined) {
          throw new Error("no reader for its channel (see schema_errors)");
        }
        const value = decoder.readMessage(message.data);
        const decoded = decoder.lastReadByteLength();
        messages.push({
          ...base,
          decoded,
          left_over: Array.from(message.data.subarray(decoded, decoded + 16)),
          value: plain(value),
        });
      } catch (error) {
        messages.push({ ...base, error: String(error) });
      }
    }
    return { schema_errors: schemaErrors, messages };
  } catch (error) {
    return { error: String(error) };
  } finally {
    await handle.close();
  }
}

const [output, ...files] = process.argv.slice(2);
if (output === undefined || files.length === 0) {
  console.error("usage: node decode_logs.mjs OUT.json FILE.mcap...");
  process.exit(2);
}
const decompressHandlers = await loadDecompressHandlers();
const result = {};
for (const file of files) {
  result[file] = await decodeFile(file, decompressHandlers);
}
await writeFile(output, JSON.stringify(result));
