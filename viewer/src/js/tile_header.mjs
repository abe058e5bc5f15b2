// What the viewer needs from the head of a tile's Draco bytes before it hands them to the decoder,
// read as common/src/tile_codec.cpp writes them (and as common/src/tile_stream.cpp walks them):
//  - the tile origin: geometry metadata "pl.origin", three little-endian float64. The positions are
//    float32 offsets from it (a whole-metre corner of the tile's points), so the decoder's floats are
//    small and exact, and the origin, in doubles, places the tile in the map's ENU frame;
//  - the unique ids of the POSITION attribute and of the GENERIC attribute whose metadata names it
//    "intensity", which three's DRACOLoader asks for by id.
// Draco's JavaScript decoder cannot read a float64 array entry, hence this walk of the bitstream:
// header, metadata (attribute metadata by unique id, then the geometry's), point count, then each
// attribute decoder's descriptors.

const POSITION = 0, GENERIC = 4;      // draco::GeometryAttribute::Type
const SEQUENTIAL = 0;                 // draco::POINT_CLOUD_SEQUENTIAL_ENCODING
const METADATA_FLAG = 0x8000;
const MAX_DEPTH = 16;

export function readTileHeader(buffer) {
  const bytes = new Uint8Array(buffer);
  const view = new DataView(buffer);
  let at = 0;
  const fail = (what) => { throw new Error(`not a tile of pl-map: ${what} at byte ${at}`); };
  const need = (n) => { if (at + n > bytes.length) fail('the Draco header is truncated'); };
  const u8 = () => { need(1); return bytes[at++]; };
  const u16 = () => { need(2); const v = view.getUint16(at, true); at += 2; return v; };
  const i32 = () => { need(4); const v = view.getInt32(at, true); at += 4; return v; };
  const varint = () => {  // Draco's: 7 bits a byte, low bits first
    let v = 0;
    for (let i = 0; i < 5; i++) {
      const b = u8();
      v += (b & 0x7f) * 2 ** (7 * i);
      if (!(b & 0x80)) return v;
    }
    fail('a malformed varint');
  };
  const name = () => { const n = u8(); need(n); const s = String.fromCharCode(...bytes.subarray(at, at + n)); at += n; return s; };
  // A metadata block: entries NAME -> bytes, then named children (skipped).
  const metadata = (depth) => {
    if (depth > MAX_DEPTH) fail('metadata nested too deep');
    const entries = new Map();
    for (let n = varint(); n > 0; n--) {
      const key = name();
      const size = varint();
      need(size);
      entries.set(key, { offset: at, size });
      at += size;
    }
    for (let n = varint(); n > 0; n--) { name(); metadata(depth + 1); }
    return entries;
  };

  need(5);
  if (String.fromCharCode(...bytes.subarray(0, 5)) !== 'DRACO') fail('no DRACO magic');
  at = 5;
  const major = u8(), minor = u8();
  u8();  // geometry type (the decoder checks it)
  const method = u8();
  const flags = u16();
  if (major !== 2) fail(`Draco bitstream ${major}.${minor} (pl-map writes 2.x)`);

  const attributeNames = new Map();  // unique id -> its metadata's "name"
  let origin = [0, 0, 0];            // no "pl.origin": positions are ENU already (tile_codec.hpp)
  if (flags & METADATA_FLAG) {
    for (let n = varint(); n > 0; n--) {
      const id = varint();
      const entry = metadata(1).get('name');
      if (entry) attributeNames.set(id, String.fromCharCode(...bytes.subarray(entry.offset, entry.offset + entry.size)));
    }
    const o = metadata(1).get('pl.origin');
    if (o) {
      if (o.size !== 24) fail('"pl.origin" is not three float64');
      origin = [0, 1, 2].map((i) => view.getFloat64(o.offset + 8 * i, true));
      if (!origin.every(Number.isFinite)) fail('"pl.origin" is not finite');
    }
  }
  const points = i32();
  let position, intensity;
  for (let d = u8(); d > 0; d--) {
    const count = varint();
    for (let a = 0; a < count; a++) {
      const type = u8();
      u8(); u8(); u8();  // data type, components, normalized
      const id = varint();
      if (type === POSITION && position === undefined) position = id;
      if (type === GENERIC && attributeNames.get(id) === 'intensity') intensity = id;
    }
    if (method === SEQUENTIAL) { need(count); at += count; }  // each attribute's decoder type
  }
  if (position === undefined) fail('no POSITION attribute');
  return { origin, points, position, intensity };
}
