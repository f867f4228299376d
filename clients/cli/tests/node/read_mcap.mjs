// Opens an MCAP file with Foxglove's TypeScript reader (the library the
// Foxglove app uses) and prints its channels, schemas and message counts.
import { McapIndexedReader } from "@mcap/core";
import { FileHandleReadable } from "@mcap/nodejs";
import { open } from "node:fs/promises";

const handle = await open(process.argv[2], "r");
const reader = await McapIndexedReader.Initialize({ readable: new FileHandleReadable(handle) });
const counts = reader.statistics?.channelMessageCounts ?? new Map();
for (const ch of [...reader.channelsById.values()].sort((a, b) => a.topic.localeCompare(b.topic))) {
  const schema = reader.schemasById.get(ch.schemaId);
  console.log(ch.topic, ch.messageEncoding, schema ? `${schema.name}/${schema.encoding}` : "-", String(counts.get(ch.id) ?? 0));
}
let n = 0;
for await (const m of reader.readMessages()) {
  n += 1;
  const ch = reader.channelsById.get(m.channelId);
  if (ch.messageEncoding === "json") JSON.parse(new TextDecoder().decode(m.data));
}
console.log(`${n} messages, every json one parsed`);
await handle.close();
