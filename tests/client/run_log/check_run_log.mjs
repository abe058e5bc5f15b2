// Reads a `pl-localize --log` file with an MCAP reader not written here (@mcap/core, zstd by fzstd)
// and checks every channel against what Foxglove needs and against the run's own outputs.
//
//   node check_run_log.mjs --modules DIR --log run.mcap --poses poses.tum --scans N [--gps] [--min-maps K]
//
// --modules: the folder `npm ci` installed package.json's dependencies into (node_modules inside).
// --poses:   the run's TUM file: /pose must hold the same poses (within 1e-6) at the same times.
// --scans:   the scans localized: /scan and /health hold one message each.
// --gps:     the drive has GPS fixes: /gps must hold some.
// --min-maps: /map must hold at least K messages (the ROI's tiles changed K - 1 times), each one
//            different from the one before it (default 1).
// Both of @mcap/core's readers read the file: the indexed one (from the footer, the summary and the
// chunk and message indexes) and the stream one (record by record from the start); they must agree.
// Exits 1 naming every failure; prints a line per channel when all is well.
import { readFileSync } from "node:fs";
import { createRequire } from "node:module";
import path from "node:path";

const args = {};
for (let i = 2; i < process.argv.length; ++i) {
  const a = process.argv[i];
  if (!a.startsWith("--")) usage(`unexpected argument ${a}`);
  if (a === "--gps") args.gps = true;
  else if (i + 1 < process.argv.length) args[a.slice(2)] = process.argv[++i];
  else usage(`${a} needs a value`);
}
function usage(problem) {
  console.error(`check_run_log: ${problem}\nusage: node check_run_log.mjs --modules DIR --log FILE --poses FILE.tum --scans N [--gps] [--min-maps K]`);
  process.exit(2);
}
for (const k of ["modules", "log", "poses", "scans"]) if (!(k in args)) usage(`--${k} is missing`);

const require = createRequire(path.join(path.resolve(args.modules), "package.json"));
let mcap, fzstd;
try {
  mcap = require("@mcap/core");
  fzstd = require("fzstd");
} catch (e) {
  console.error(`check_run_log: cannot load @mcap/core / fzstd from ${args.modules}/node_modules (${e.message}); run npm ci there`);
  process.exit(2);
}

const failures = [];
function fail(what) {
  if (failures.length < 200) failures.push(what);
}
function check(ok, what) {
  if (!ok) fail(what);
  return ok;
}

const decompressHandlers = { zstd: (data, size) => fzstd.decompress(data, new Uint8Array(Number(size))) };
const file = readFileSync(args.log);
const bytes = new Uint8Array(file.buffer, file.byteOffset, file.byteLength);

// --- what each channel must be ---
const expected = {
  "/pose": "foxglove.PoseInFrame",
  "/tf": "foxglove.FrameTransform",
  "/scan": "foxglove.PointCloud",
  "/map": "foxglove.PointCloud",
  "/gps": "foxglove.LocationFix",
  "/health": "pl.ScanReport",
};

// --- the indexed reader ---
const readable = {
  size: async () => BigInt(bytes.length),
  read: async (offset, size) => bytes.subarray(Number(offset), Number(offset + size)),
};
const indexed = await mcap.McapIndexedReader.Initialize({ readable, decompressHandlers });
check(indexed.header.profile === "", `the Header's profile is "${indexed.header.profile}", expected ""`);
check(indexed.chunkIndexes.length > 0, "no Chunk Index records in the summary");
check(indexed.statistics !== undefined, "no Statistics record in the summary");
const topicOf = new Map();
for (const [id, ch] of indexed.channelsById) {
  topicOf.set(id, ch.topic);
  const schema = indexed.schemasById.get(ch.schemaId);
  if (!check(ch.topic in expected, `unexpected channel ${ch.topic}`)) continue;
  check(ch.messageEncoding === "json", `${ch.topic}: message encoding "${ch.messageEncoding}", expected "json"`);
  if (!check(schema !== undefined, `${ch.topic}: its schema ${ch.schemaId} is not in the summary`)) continue;
  check(schema.name === expected[ch.topic], `${ch.topic}: schema "${schema.name}", expected "${expected[ch.topic]}"`);
  check(schema.encoding === "jsonschema", `${ch.topic}: schema encoding "${schema.encoding}", expected "jsonschema"`);
  try {
    const doc = JSON.parse(new TextDecoder().decode(schema.data));
    check(doc.title === schema.name, `${ch.topic}: the JSON Schema's title "${doc.title}" is not its name "${schema.name}"`);
    check(doc.type === "object" && typeof doc.properties === "object", `${ch.topic}: the JSON Schema describes no object`);
  } catch (e) {
    fail(`${ch.topic}: its schema is not JSON: ${e.message}`);
  }
}
for (const topic of Object.keys(expected))
  check([...indexed.channelsById.values()].some((c) => c.topic === topic), `no channel ${topic}`);

const byIndex = new Map();  // topic -> [{logTime, data}]
for await (const m of indexed.readMessages()) {
  const topic = topicOf.get(m.channelId);
  if (!byIndex.has(topic)) byIndex.set(topic, []);
  byIndex.get(topic).push(m);
}
const stats = indexed.statistics;
if (stats) {
  let total = 0;
  for (const list of byIndex.values()) total += list.length;
  check(Number(stats.messageCount) === total, `Statistics says ${stats.messageCount} messages, the indexed reader read ${total}`);
  for (const [id, n] of stats.channelMessageCounts)
    check(Number(n) === (byIndex.get(topicOf.get(id)) ?? []).length,
          `Statistics says ${n} messages on ${topicOf.get(id)}, the indexed reader read ${(byIndex.get(topicOf.get(id)) ?? []).length}`);
}

// --- the stream reader ---
const stream = new mcap.McapStreamReader({ decompressHandlers, validateCrcs: true });
stream.append(bytes);
const byStream = new Map();
let dataEndCrc, footer;
for (let r; (r = stream.nextRecord()); ) {
  if (r.type === "Message") {
    const topic = topicOf.get(r.channelId);
    if (!byStream.has(topic)) byStream.set(topic, []);
    byStream.get(topic).push(r);
  } else if (r.type === "DataEnd") {
    dataEndCrc = r.dataSectionCrc;
  } else if (r.type === "Footer") {
    footer = r;
  }
}
check(stream.done(), "the stream reader did not reach the closing magic");
check(footer !== undefined, "the stream reader saw no Footer");
// The Data End record's CRC covers every byte before it.
function crc32(buf) {
  let c = ~0;
  for (let i = 0; i < buf.length; ++i) {
    c ^= buf[i];
    for (let k = 0; k < 8; ++k) c = (c >>> 1) ^ (0xedb88320 & -(c & 1));
  }
  return ~c >>> 0;
}
if (check(dataEndCrc !== undefined && dataEndCrc !== 0, "the Data End record has no data section CRC"))
  check(crc32(bytes.subarray(0, Number(indexed.dataEndOffset))) === dataEndCrc, "the Data End record's CRC does not match the data section");

// Both readers: the same messages, the same bytes, per channel in file order (log times non-decreasing).
for (const topic of Object.keys(expected)) {
  const a = byIndex.get(topic) ?? [], b = byStream.get(topic) ?? [];
  if (!check(a.length === b.length, `${topic}: the indexed reader read ${a.length} messages, the stream reader ${b.length}`)) continue;
  for (let i = 0; i < a.length; ++i) {
    if (a[i].logTime !== b[i].logTime || Buffer.compare(Buffer.from(a[i].data), Buffer.from(b[i].data)) !== 0) {
      fail(`${topic}: message ${i} differs between the indexed and the stream reader`);
      break;
    }
    if (i > 0 && b[i].logTime < b[i - 1].logTime) {
      fail(`${topic}: message ${i}'s log time ${b[i].logTime} goes back from ${b[i - 1].logTime}`);
      break;
    }
  }
}

// --- each channel's JSON ---
const schemaOf = new Map([...indexed.channelsById.values()].map((c) => {
  try {
    return [c.topic, JSON.parse(new TextDecoder().decode(indexed.schemasById.get(c.schemaId).data))];
  } catch {
    return [c.topic, {}];
  }
}));
function parsed(topic) {
  const out = [];
  for (const [i, m] of (byStream.get(topic) ?? []).entries()) {
    let j;
    try {
      j = JSON.parse(new TextDecoder().decode(m.data));
    } catch (e) {
      fail(`${topic}: message ${i} is not JSON: ${e.message}`);
      continue;
    }
    for (const k of schemaOf.get(topic)?.required ?? [])
      check(k in j, `${topic}: message ${i} has no "${k}", which its schema requires`);
    const ts = j.timestamp;
    if (check(ts && Number.isInteger(ts.sec) && Number.isInteger(ts.nsec) && ts.nsec >= 0 && ts.nsec < 1e9,
              `${topic}: message ${i}'s timestamp is not {sec, nsec}`))
      check(BigInt(ts.sec) * 1000000000n + BigInt(ts.nsec) === m.logTime,
            `${topic}: message ${i}'s timestamp ${ts.sec}.${ts.nsec} is not its log time ${m.logTime}`);
    out.push({ j, t: Number(m.logTime) * 1e-9, i });
  }
  return out;
}
const isNum = (v) => typeof v === "number" && Number.isFinite(v);
const isVec = (v) => v && isNum(v.x) && isNum(v.y) && isNum(v.z);
const isQuat = (q) => q && isNum(q.x) && isNum(q.y) && isNum(q.z) && isNum(q.w) && Math.abs(Math.hypot(q.x, q.y, q.z, q.w) - 1) < 1e-6;

// /pose against the pose file.
const poseFile = readFileSync(args.poses, "utf8").split("\n").filter((l) => l.trim() && !l.startsWith("#")).map((l) => l.trim().split(/\s+/).map(Number));
const poses = parsed("/pose");
check(poses.length === poseFile.length, `/pose holds ${poses.length} poses, ${args.poses} ${poseFile.length}`);
for (let k = 0; k < Math.min(poses.length, poseFile.length); ++k) {
  const { j, t } = poses[k];
  const f = poseFile[k];
  if (!check(j.frame_id === "map" && isVec(j.pose?.position) && isQuat(j.pose?.orientation), `/pose ${k}: not a pose in frame "map"`)) continue;
  const p = j.pose.position, q = j.pose.orientation;
  const s = Math.sign(q.w * f[7] + q.x * f[4] + q.y * f[5] + q.z * f[6]) || 1;  // q and -q are one rotation
  const dt = Math.abs(t - f[0]);
  const dp = Math.max(Math.abs(p.x - f[1]), Math.abs(p.y - f[2]), Math.abs(p.z - f[3]));
  const dq = Math.max(Math.abs(s * q.x - f[4]), Math.abs(s * q.y - f[5]), Math.abs(s * q.z - f[6]), Math.abs(s * q.w - f[7]));
  if (dt > 1e-6 || dp > 1e-6 || dq > 1e-6) {
    fail(`/pose ${k}: t ${t} (${dt}), position off by ${dp}, rotation by ${dq} against line ${k + 1} of ${args.poses} (more than 1e-6)`);
    break;
  }
}

// /tf: map -> base, the same poses.
const tfs = parsed("/tf");
check(tfs.length === poses.length, `/tf holds ${tfs.length} transforms, /pose ${poses.length}`);
for (const { j, i } of tfs) {
  if (!check(j.parent_frame_id === "map" && j.child_frame_id === "base" && isVec(j.translation) && isQuat(j.rotation),
             `/tf ${i}: not a map -> base transform`)) break;
  const p = poses[i]?.j.pose?.position;
  if (p && !check(Math.abs(p.x - j.translation.x) + Math.abs(p.y - j.translation.y) + Math.abs(p.z - j.translation.z) < 1e-9,
                  `/tf ${i}: not /pose ${i}'s translation`)) break;
}

// Point clouds: fields x, y, z (FLOAT32), base64 data of whole points; returns the points.
function cloud(topic, i, j) {
  if (!check(j.frame_id === "map", `${topic} ${i}: frame_id "${j.frame_id}", expected "map"`)) return null;
  if (!check(isVec(j.pose?.position) && isQuat(j.pose?.orientation), `${topic} ${i}: no pose`)) return null;
  const stride = j.point_stride;
  if (!check(Number.isInteger(stride) && stride > 0, `${topic} ${i}: point_stride ${stride}`)) return null;
  const fields = new Map((j.fields ?? []).map((f) => [f.name, f]));
  for (const n of ["x", "y", "z"]) {
    const f = fields.get(n);
    if (!check(f && f.type === 7 && Number.isInteger(f.offset) && f.offset + 4 <= stride, `${topic} ${i}: field ${n} is not a FLOAT32 within the stride`))
      return null;
  }
  if (!check(typeof j.data === "string" && /^[A-Za-z0-9+/]*={0,2}$/.test(j.data) && j.data.length % 4 === 0, `${topic} ${i}: data is not base64`))
    return null;
  const raw = Buffer.from(j.data, "base64");
  const pad = j.data.endsWith("==") ? 2 : j.data.endsWith("=") ? 1 : 0;
  check(raw.length === (j.data.length / 4) * 3 - pad, `${topic} ${i}: base64 decodes to ${raw.length} bytes`);
  if (!check(raw.length > 0 && raw.length % stride === 0, `${topic} ${i}: ${raw.length} bytes of data is not a whole number of ${stride}-byte points`))
    return null;
  const n = raw.length / stride;
  const pts = [];
  for (let k = 0; k < n; ++k) {
    const at = k * stride;
    const p = [raw.readFloatLE(at + fields.get("x").offset), raw.readFloatLE(at + fields.get("y").offset), raw.readFloatLE(at + fields.get("z").offset)];
    if (!p.every(Number.isFinite)) {
      fail(`${topic} ${i}: point ${k} is not finite`);
      return null;
    }
    pts.push(p);
  }
  return pts;
}
const scans = Number(args.scans);
const scanMsgs = parsed("/scan");
check(scanMsgs.length === scans, `/scan holds ${scanMsgs.length} scans, the run localized ${scans}`);
let scanPoints = 0;
for (const { j, t, i } of scanMsgs) {
  const pts = cloud("/scan", i, j);
  if (!pts) continue;
  scanPoints += pts.length;
  // Placed in the map frame: about the pose of the vehicle then (within the scan's range).
  let near = poses[0];
  for (const p of poses) if (Math.abs(p.t - t) < Math.abs(near.t - t)) near = p;
  const c = near?.j.pose?.position;
  if (c) {
    const far = pts.filter((p) => Math.hypot(p[0] - c.x, p[1] - c.y) > 150).length;
    check(far === 0, `/scan ${i}: ${far} points more than 150 m from the vehicle: not in the map frame?`);
  }
}
const maps = parsed("/map");
const minMaps = Number(args["min-maps"] ?? 1);
check(maps.length >= minMaps, `/map holds ${maps.length} messages, expected at least ${minMaps}`);
let mapPoints = 0;
for (const { j, i } of maps) {
  mapPoints += cloud("/map", i, j)?.length ?? 0;
  if (i > 0) check(j.data !== maps[i - 1].j.data, `/map ${i} is the same map as /map ${i - 1}: written again with no change`);
}

// /gps
const fixes = parsed("/gps");
if (args.gps) check(fixes.length > 0, "/gps holds no fix, and the drive has some");
for (const { j, i } of fixes) {
  if (!check(isNum(j.latitude) && Math.abs(j.latitude) <= 90 && isNum(j.longitude) && Math.abs(j.longitude) <= 180 && isNum(j.altitude),
             `/gps ${i}: no latitude, longitude, altitude`)) break;
  if (!check(Array.isArray(j.position_covariance) && j.position_covariance.length === 9 && j.position_covariance.every(isNum) &&
             [0, 1, 2, 3].includes(j.position_covariance_type), `/gps ${i}: no covariance of 9 numbers and a type 0-3`)) break;
}

// /health: one per scan, at the scan times.
const health = parsed("/health");
check(health.length === scans, `/health holds ${health.length} reports, the run localized ${scans}`);
const counts = { ok: 0, degraded: 0, lost: 0 };
for (const { j, t, i } of health) {
  if (!check(j.health in counts, `/health ${i}: health "${j.health}"`)) break;
  counts[j.health]++;
  const ok = typeof j.note === "string" && isNum(j.protection_m) && isNum(j.registration_sigma_m) && Number.isInteger(j.icp?.iterations) &&
             isNum(j.icp?.fitness) && isNum(j.icp?.rms_m) && Number.isInteger(j.map_tiles) && Number.isInteger(j.map_points) &&
             ["prepare", "map", "register", "integrity"].every((k) => isNum(j.timing_ms?.[k]));
  if (!check(ok, `/health ${i}: a field is missing or not a number: ${JSON.stringify(j).slice(0, 300)}`)) break;
  if (scanMsgs[i]) check(Math.abs(scanMsgs[i].t - t) < 1e-9, `/health ${i} is not at /scan ${i}'s time`);
}

if (failures.length) {
  console.error(`check_run_log: ${args.log}: ${failures.length} problem(s):`);
  for (const f of failures) console.error(`  ${f}`);
  process.exit(1);
}
const size = (topic) => (byStream.get(topic) ?? []).reduce((s, m) => s + m.data.length, 0);
console.log(`check_run_log: ${args.log} (${bytes.length} bytes, ${indexed.chunkIndexes.length} chunks) read by @mcap/core's indexed and stream readers:`);
console.log(`  /pose ${poses.length} = ${args.poses}'s lines, /tf ${tfs.length}; JSON ${size("/pose") + size("/tf")} bytes`);
console.log(`  /scan ${scanMsgs.length} scans, ${scanPoints} points; JSON ${size("/scan")} bytes`);
console.log(`  /map ${maps.length} messages, ${mapPoints} points; JSON ${size("/map")} bytes`);
console.log(`  /gps ${fixes.length} fixes; /health ${health.length} reports (${counts.ok} ok, ${counts.degraded} degraded, ${counts.lost} lost); JSON ${size("/gps") + size("/health")} bytes`);
