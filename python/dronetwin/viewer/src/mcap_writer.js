// The MCAP writer of `dronetwin export --mcap` (python/dronetwin/export.py; docs/ros.md).
//
//   node mcap_writer.js OUT.mcap < records
//
// Reads the messages python/dronetwin/export.py serialised (ROS 1 wire format, with their
// message definitions) from stdin and writes them with @mcap/core, the MCAP project's own
// TypeScript library: ros1 profile, chunked and indexed (chunk, message and summary indexes,
// statistics), uncompressed. The input is a little-endian stream after the 8 bytes "DTMCAPIN":
//   1 schema:  u16 id, u32 n, n bytes name ("nav_msgs/Odometry"), u32 n, n bytes definition
//   2 channel: u16 id, u16 schema id, u32 n, n bytes topic
//   3 message: u16 channel id, u64 time (ns), u32 n, n bytes serialised message
// Exit status: 0 written, 2 bad input or output (a message on stderr names it).

import { McapWriter } from "@mcap/core";
import { open } from "node:fs/promises";

class FileWritable {
  constructor(handle) {
    this.handle = handle;
    this.offset = 0n;
  }

  async write(buffer) {
    await this.handle.write(buffer);
    this.offset += BigInt(buffer.byteLength);
  }

  position() {
    return this.offset;
  }
}

async function readStdin() {
  const parts = [];
  for await (const part of process.stdin) parts.push(part);
  return Buffer.concat(parts);
}

function fail(message) {
  process.stderr.write(`mcap_writer: ${message}\n`);
  process.exit(2);
}

async function main() {
  const out = process.argv[2];
  if (!out) fail("usage: node mcap_writer.js OUT.mcap < records");
  const input = await readStdin();
  if (input.subarray(0, 8).toString("latin1") !== "DTMCAPIN") fail("stdin: not a record stream");
  let at = 8;
  const need = (n) => {
    if (at + n > input.length) fail(`stdin: record cut off at byte ${at} (needs ${n} more)`);
  };
  const u16 = () => (need(2), (at += 2), input.readUInt16LE(at - 2));
  const u32 = () => (need(4), (at += 4), input.readUInt32LE(at - 4));
  const u64 = () => (need(8), (at += 8), input.readBigUInt64LE(at - 8));
  const bytes = () => {
    const n = u32();
    need(n);
    at += n;
    return input.subarray(at - n, at);
  };

  const handle = await open(out, "wx").catch((e) => fail(`${out}: ${e.message}`));
  const writer = new McapWriter({
    writable: new FileWritable(handle),
    useStatistics: true,
    useSummaryOffsets: true,
    useChunks: true,
    chunkSize: 1 << 20,
  });
  await writer.start({ profile: "ros1", library: "dronetwin (@mcap/core)" });
  const schemas = new Map(); // input id -> writer id
  const channels = new Map();
  const sequence = new Map();
  while (at < input.length) {
    const op = input[at++];
    if (op === 1) {
      const id = u16();
      const name = bytes().toString("utf8");
      const data = bytes();
      schemas.set(id, await writer.registerSchema({ name, encoding: "ros1msg", data }));
    } else if (op === 2) {
      const id = u16();
      const schema = u16();
      const topic = bytes().toString("utf8");
      if (!schemas.has(schema)) fail(`channel ${topic}: unknown schema ${schema}`);
      channels.set(
        id,
        await writer.registerChannel({
          topic,
          schemaId: schemas.get(schema),
          messageEncoding: "ros1",
          metadata: new Map(),
        }),
      );
    } else if (op === 3) {
      const id = u16();
      const time = u64();
      const data = bytes();
      if (!channels.has(id)) fail(`message at byte ${at}: unknown channel ${id}`);
      const n = sequence.get(id) ?? 0;
      sequence.set(id, n + 1);
      await writer.addMessage({
        channelId: channels.get(id),
        sequence: n,
        logTime: time,
        publishTime: time,
        data,
      });
    } else {
      fail(`stdin: unknown record ${op} at byte ${at - 1}`);
    }
  }
  await writer.end();
  await handle.close();
}

main().catch((e) => fail(e.stack || String(e)));
