// Signed maps: a version's manifest (the map, the version and its parent, the ENU origin and grid,
// its places and every tile's key and content hash) in one canonical text, signed with Ed25519
// (OpenSSL) by whoever publishes it, and verified by the vehicle before it uses any tile of the
// version. Each tile's bytes are then checked against the manifest's hash, so a tile or manifest
// altered anywhere between the store and the vehicle (a cache, the network, a replica) is refused.
//
// The text, one field a line, each line ending in '\n', numbers as printf's %lld and %.17g (which
// read back exactly), tiles ordered by (tx, ty):
//
//   pointlocalization-manifest 1
//   map NAME
//   version N
//   parent N | parent none
//   origin LAT LON ALT
//   tile_size METRES
//   voxel_size METRES
//   places HASH | places none
//   tiles COUNT
//   TX TY HASH POINTS        (COUNT lines)
//
// A signed manifest, as pl-server serves it, is that text followed by one more line:
//
//   signature ed25519 PUBLIC_KEY SIGNATURE     (both base64: 32 and 64 bytes)
//
// and the signature is over the bytes of the text before that line, exactly.
//
// Keys are PEM files as OpenSSL writes them: a PKCS#8 private key ("openssl genpkey -algorithm
// ed25519", or pl-map key-gen) and its SubjectPublicKeyInfo public key ("openssl pkey -pubout").
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/common/geo.hpp"
#include "pl/common/tile_key.hpp"

namespace pl::store {
class Store;
}

namespace pl::signing {

// A manifest or signature that does not parse or does not verify; what() says what is wrong.
struct ManifestError : Error {
  using Error::Error;
};

// The largest manifest text read (about 3 million tiles).
inline constexpr std::size_t kMaxManifestBytes = std::size_t{256} << 20;

struct ManifestTile {
  TileKey key;
  std::string hash;  // SHA-256 of the tile's Draco bytes, lowercase hex
  std::int64_t points = 0;
  bool operator==(const ManifestTile& o) const { return key == o.key && hash == o.hash && points == o.points; }
};

struct Manifest {
  std::string map;
  std::int64_t version = 0;
  std::optional<std::int64_t> parent;
  GeoPoint origin;
  double tile_size = 0, voxel_size = 0;
  std::optional<std::string> places;  // the places' SHA-256, when the version has places
  std::vector<ManifestTile> tiles;    // ordered by key, one per key
};

// The version's manifest as the store holds it. Throws pl::Error for an unknown map or version.
Manifest manifest_of(const store::Store& store, const std::string& map, std::int64_t version);

// The canonical text of a manifest (the bytes that are signed). Throws pl::Error for a manifest no
// store holds (an invalid map name or hash, tiles out of order, a size that is not positive).
std::string manifest_text(const Manifest& m);

// Reads a manifest's text (without a signature line), strictly: it must be exactly what
// manifest_text writes for what it says. Throws ManifestError naming the line and the problem.
Manifest parse_manifest_text(std::string_view text);

// A public key's id in messages and logs: the first 16 hex digits of the SHA-256 of its 32 bytes.
std::string key_id(std::string_view public_key);

// An Ed25519 private key.
class SigningKey {
 public:
  static SigningKey generate();
  // The key whose 32-byte private key (RFC 8032's seed) is `seed`: fixed keys for tests and seeds.
  static SigningKey from_seed(std::string_view seed);
  // A PKCS#8 PEM file of an Ed25519 key. Throws pl::Error naming the file and the problem.
  static SigningKey load(const std::string& pem_file);
  SigningKey(SigningKey&&) noexcept;
  SigningKey& operator=(SigningKey&&) noexcept;
  ~SigningKey();

  // Writes the key as PKCS#8 PEM, readable by its owner only (mode 0600); never over an existing file.
  void save(const std::string& pem_file) const;
  const std::string& public_key() const { return public_key_; }  // 32 bytes
  std::string sign(std::string_view message) const;             // 64 bytes

 private:
  SigningKey() = default;
  explicit SigningKey(void* evp_pkey);  // takes the key, freeing it should reading its public half fail
  void* key_ = nullptr;  // EVP_PKEY
  std::string public_key_;
};

// The public keys (32 bytes each) of a PEM file: one or more "-----BEGIN PUBLIC KEY-----" blocks of
// Ed25519 keys (several while a fleet moves to a new key). Throws pl::Error naming the file.
std::vector<std::string> load_public_keys(const std::string& pem_file);
// The key as a PEM file's text.
std::string public_key_pem(std::string_view public_key);
// Writes a public key's PEM file (never over an existing file).
void save_public_key(std::string_view public_key, const std::string& pem_file);

// Whether `signature` (64 bytes) is `public_key`'s (32 bytes) over `message`.
bool verify(std::string_view public_key, std::string_view message, std::string_view signature);

// Signs a staged version in the caller's Store::Transaction, just before it is published: stores
// the signature (put_signature; on PostgreSQL that takes the map's lock, so no writer comes
// between), then checks it against the version's manifest as the store now holds it. Throws
// SignatureMismatch when it does not verify (the version was written to after the manifest was
// read to be signed, or the bytes signed were not its manifest): roll the transaction back. Both
// signing publishers use it: pl-map publish --signing-key, and pl-server taking a signed publish.
struct SignatureMismatch : Error {
  using Error::Error;
};
void sign_staged_version(store::Store& s, const std::string& map, std::int64_t version, std::string_view public_key,
                         std::string_view signature);

// The line a signed manifest ends with.
std::string signature_line(std::string_view public_key, std::string_view signature);

// A signed text as pl-server serves one (a manifest; a current-version statement,
// pl/schema/signed_current.hpp): the text, then one "signature ed25519 KEY SIGNATURE" line over the
// text's bytes. Splits `body` at that line and checks the signature against `trusted` (public keys,
// 32 bytes each). Messages name the text as `noun` ("manifest"), say `unsigned_fix` for a text that
// carries no signature, and name the trusted keys as `keys` ("the fleet's keys"). Throws
// ManifestError; returns the text (a view into body) and the key that signed it.
struct VerifiedText {
  std::string_view text;
  std::string public_key;
};
VerifiedText verify_signed_text(std::string_view body, const std::vector<std::string>& trusted, std::size_t max_text_bytes,
                                const std::string& noun, const std::string& unsigned_fix, const std::string& keys);

struct SignedManifest {
  Manifest manifest;
  std::string text;        // the manifest's text (the signed bytes)
  std::string public_key;  // the key it verified against (one of the trusted)
};

// A signed manifest as served: parsed, and its signature checked against `trusted` (public keys,
// 32 bytes each). Throws ManifestError when it does not parse, carries no signature, is signed by
// a key not among the trusted, or its signature does not verify.
SignedManifest verify_signed_manifest(std::string_view body, const std::vector<std::string>& trusted);

// base64 (standard alphabet, padded), and back: decode_base64 returns nothing for text that is not.
std::string encode_base64(std::string_view bytes);
std::optional<std::string> decode_base64(std::string_view text);

}  // namespace pl::signing
