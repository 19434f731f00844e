// A Foxglove WebSocket client of `sail-ros bridge`, as the Foxglove app is one:
// @foxglove/ws-protocol's FoxgloveClient on the `ws` package, messages decoded and
// commands encoded by @foxglove/rosmsg2-serialization from the advertised ros2msg schemas.
//
//   node bridge_client.mjs URL OUT.json STEPS.json
//
// Connects, waits for the channels of STEPS.topics (a list of names) to be advertised,
// subscribes to every channel (or those of STEPS.subscribe), waits for a first message on
// each topic of STEPS.receiving (the bridge has then found the simulator's publishers: a
// channel exists from the bridge's start), then runs STEPS.steps in order:
//   {"wait": seconds}
//   {"publish": {"topic", "type", "value"}}       advertise (once per topic), encode, send
//   {"publish_hex": {"topic", "type", "hex"}}     the same with these bytes as they are
//   {"call": {"service", "value"}}                a service call, its response decoded
//   {"stall": seconds}                            stop reading the socket that long
// and writes OUT.json: {server_info, channels: [{id, topic, encoding, schemaName,
// schemaEncoding, schema}], services: [...], statuses: [{level, message}], calls:
// [{service, response} or {service, error}], errors: [text], received: {topic: count},
// messages: [{topic,
// arrival_ns, log_time_ns, stamp_ns, sha256, size, value?}]}. `value` (decoded) only for the topics in
// STEPS.keep_values; `stamp_ns` is the stamp (header's, the first marker's, stamp or clock) as decimal text
// when the message has one;
// `arrival_ns` is this machine's wall clock [ns] when the message was decoded.

import { createHash } from "node:crypto";
import { readFile, writeFile } from "node:fs/promises";

import { parse } from "@foxglove/rosmsg";
import { MessageReader, MessageWriter } from "@foxglove/rosmsg2-serialization";
import wsProtocol from "@foxglove/ws-protocol";
import WebSocket from "ws";

const { FoxgloveClient } = wsProtocol;
const SUBPROTOCOL = "foxglove.sdk.v1"; // what foxglove-sdk's server speaks
const CONNECT_TIMEOUT_MS = 20000;

const [url, outPath, stepsPath] = process.argv.slice(2);
const plan = JSON.parse(await readFile(stepsPath, "utf8"));
const keepValues = new Set(plan.keep_values ?? []);

function stampOf(value) {
  const time = value?.header?.stamp ?? value?.markers?.[0]?.header.stamp ?? value?.stamp ?? value?.clock;
  return time === undefined ? null : (BigInt(time.sec) * 1000000000n + BigInt(time.nanosec)).toString();
}

function definitions(schemaText) {
  return parse(schemaText, { ros2: true });
}

const ws = new WebSocket(url, [SUBPROTOCOL]);
const client = new FoxgloveClient({ ws });
const out = {
  server_info: null,
  channels: [],
  services: [],
  statuses: [],
  calls: [],
  received: {},
  messages: [],
  errors: [],
};
const readers = new Map(); // subscription id -> {topic, reader}
const pendingCalls = new Map(); // call id -> resolve
const advertised = new Map(); // topic -> client channel id
let nextCallId = 1;

client.on("serverInfo", (info) => {
  out.server_info = info;
});
client.on("status", (status) => out.statuses.push({ level: status.level, message: status.message }));
client.on("advertise", (channels) => {
  for (const channel of channels) {
    if (out.channels.some((known) => known.id === channel.id)) {
      // advertised again (a channel added while the server greeted this client)
      out.readvertised = (out.readvertised ?? 0) + 1;
      continue;
    }
    out.channels.push(channel);
    if (plan.subscribe !== undefined && !plan.subscribe.includes(channel.topic)) {
      continue;
    }
    const id = client.subscribe(channel.id);
    readers.set(id, { topic: channel.topic, reader: new MessageReader(definitions(channel.schema)) });
  }
});
client.on("error", (error) => out.errors.push(String(error?.stack ?? error)));
client.on("advertiseServices", (services) => out.services.push(...services));
client.on("message", ({ subscriptionId, timestamp, data }) => {
  const arrival = BigInt(Math.round((performance.timeOrigin + performance.now()) * 1e6));
  const { topic, reader } = readers.get(subscriptionId);
  const bytes = new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
  const value = reader.readMessage(bytes);
  out.received[topic] = (out.received[topic] ?? 0) + 1;
  const entry = {
    topic,
    arrival_ns: arrival.toString(),
    log_time_ns: timestamp.toString(),
    stamp_ns: stampOf(value),
    sha256: createHash("sha256").update(bytes).digest("hex"),
    size: bytes.length,
  };
  if (keepValues.has(topic)) {
    entry.value = value;
  }
  out.messages.push(entry);
});
client.on("serviceCallResponse", (response) => {
  pendingCalls.get(response.callId)?.({ response });
});
client.on("serviceCallFailure", (failure) => {
  pendingCalls.get(failure.callId)?.({ error: failure.message });
});

const sleep = (seconds) => new Promise((resolve) => setTimeout(resolve, seconds * 1000));

async function until(condition, what) {
  const deadline = Date.now() + CONNECT_TIMEOUT_MS;
  while (!condition()) {
    if (Date.now() > deadline) {
      throw new Error(`timed out waiting for ${what}`);
    }
    await sleep(0.02);
  }
}

function channelOf(topic, type) {
  if (!advertised.has(topic)) {
    const schema = out.channels.find((channel) => channel.schemaName === type)?.schema;
    advertised.set(
      topic,
      client.advertise({
        topic,
        encoding: "cdr",
        schemaName: type,
        schemaEncoding: "ros2msg",
        schema: schema ?? "",
      }),
    );
  }
  return advertised.get(topic);
}

async function definitionOf(type) {
  // the schema the bridge advertised for a channel of that type (every command type is
  // also a served topic's type)
  const channel = out.channels.find((candidate) => candidate.schemaName === type);
  if (channel === undefined) {
    throw new Error(`no channel of type ${type} advertised to take its schema from`);
  }
  return definitions(channel.schema);
}

async function run(step) {
  if ("wait" in step) {
    await sleep(step.wait);
  } else if ("publish" in step) {
    const { topic, type, value } = step.publish;
    const writer = new MessageWriter(await definitionOf(type));
    client.sendMessage(channelOf(topic, type), writer.writeMessage(value));
  } else if ("publish_hex" in step) {
    const { topic, type, hex } = step.publish_hex;
    client.sendMessage(channelOf(topic, type), Uint8Array.from(Buffer.from(hex, "hex")));
  } else if ("call" in step) {
    const { service: name, value } = step.call;
    const service = out.services.find((candidate) => candidate.name === name);
    if (service === undefined) {
      throw new Error(`service ${name} not advertised`);
    }
    const request = new MessageWriter(definitions(service.request.schema)).writeMessage(value);
    const callId = nextCallId++;
    const answer = new Promise((resolve) => pendingCalls.set(callId, resolve));
    client.sendServiceCallRequest({ serviceId: service.id, callId, encoding: "cdr", data: request });
    const { response, error } = await answer;
    if (error !== undefined) {
      out.calls.push({ service: name, error });
    } else {
      const reader = new MessageReader(definitions(service.response.schema));
      const bytes = new Uint8Array(response.data.buffer, response.data.byteOffset, response.data.byteLength);
      out.calls.push({ service: name, response: reader.readMessage(bytes) });
    }
  } else if ("stall" in step) {
    ws._socket.pause(); // the kernel's buffers fill, then the server's queue for this client
    await sleep(step.stall);
    ws._socket.resume();
  }
}

try {
  await new Promise((resolve, reject) => {
    ws.once("open", resolve);
    ws.once("error", reject);
  });
  await until(
    () => (plan.topics ?? []).every((topic) => out.channels.some((c) => c.topic === topic)),
    `channels ${JSON.stringify(plan.topics)}`,
  );
  await until(
    () => (plan.receiving ?? []).every((topic) => (out.received[topic] ?? 0) > 0),
    `a first message on ${JSON.stringify(plan.receiving)}`,
  );
  for (const step of plan.steps ?? []) {
    await run(step);
  }
} finally {
  client.close();
  // typed arrays as arrays, 64-bit integers as numbers
  const plain = (key, value) =>
    ArrayBuffer.isView(value) ? Array.from(value) : typeof value === "bigint" ? Number(value) : value;
  await writeFile(outPath, JSON.stringify(out, plain));
}
