// Signed manifests (pl/schema/signed_manifest.hpp): the canonical text, Ed25519 through OpenSSL's
// EVP interface, PEM key files.
#include "pl/schema/signed_manifest.hpp"

#include <fcntl.h>
#include <openssl/bio.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <climits>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <utility>

#include "pl/schema/api_rules.hpp"
#include "pl/schema/store.hpp"

namespace pl::signing {

namespace {

constexpr std::string_view kMagic = "pointlocalization-manifest 1";
constexpr std::size_t kPublicKeyBytes = 32, kSignatureBytes = 64;

std::string openssl_error() {
  const unsigned long e = ERR_get_error();
  ERR_clear_error();
  if (e == 0) return "no detail from OpenSSL";
  char buf[256];
  ERR_error_string_n(e, buf, sizeof(buf));
  return buf;
}

struct PkeyFree {
  void operator()(EVP_PKEY* k) const { EVP_PKEY_free(k); }
};
using Pkey = std::unique_ptr<EVP_PKEY, PkeyFree>;
struct MdCtxFree {
  void operator()(EVP_MD_CTX* c) const { EVP_MD_CTX_free(c); }
};
using MdCtx = std::unique_ptr<EVP_MD_CTX, MdCtxFree>;
struct BioFree {
  void operator()(BIO* b) const { BIO_free(b); }
};
using Bio = std::unique_ptr<BIO, BioFree>;

std::string raw_public_key(EVP_PKEY* k) {
  std::size_t n = kPublicKeyBytes;
  std::string out(n, '\0');
  if (EVP_PKEY_get_raw_public_key(k, reinterpret_cast<unsigned char*>(out.data()), &n) != 1 || n != kPublicKeyBytes)
    throw Error("cannot read an Ed25519 public key: " + openssl_error());
  return out;
}

Pkey public_pkey(std::string_view public_key) {
  if (public_key.size() != kPublicKeyBytes)
    throw Error("an Ed25519 public key is 32 bytes, got " + std::to_string(public_key.size()));
  Pkey k(EVP_PKEY_new_raw_public_key(EVP_PKEY_ED25519, nullptr, reinterpret_cast<const unsigned char*>(public_key.data()),
                                     public_key.size()));
  if (!k) throw Error("not an Ed25519 public key: " + openssl_error());
  return k;
}

std::string read_small_file(const std::string& path) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!f) throw Error(path + ": cannot open: " + std::strerror(errno));
  std::string out;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof(buf), f.get())) > 0) {
    out.append(buf, n);
    if (out.size() > (1u << 20)) throw Error(path + ": more than 1 MiB: not a PEM key file");
  }
  if (std::ferror(f.get())) throw Error(path + ": cannot read: " + std::strerror(errno));
  return out;
}

// Writes `text` to a new file (O_EXCL: never over an existing one) with `mode`.
void write_new_file(const std::string& path, const std::string& text, mode_t mode) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, mode);
  if (fd < 0)
    throw Error(path + ": cannot create: " + std::strerror(errno) +
                (errno == EEXIST ? " (a key is never written over: move the old one away first)" : ""));
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string why = std::strerror(errno);
      ::close(fd);
      ::unlink(path.c_str());
      throw Error(path + ": cannot write: " + why);
    }
    done += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) throw Error(path + ": cannot write: " + std::strerror(errno));
}

std::string format_double(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

// ---- reading the text, strictly

class Lines {
 public:
  explicit Lines(std::string_view text) : text_(text) {}
  // The next line without its '\n'; every line must end in one.
  std::string_view next(const char* what) {
    if (pos_ >= text_.size()) bad("ends before its " + std::string(what) + " line");
    const std::size_t end = text_.find('\n', pos_);
    if (end == std::string_view::npos) bad("its last line has no line end");
    std::string_view line = text_.substr(pos_, end - pos_);
    pos_ = end + 1;
    ++number_;
    return line;
  }
  bool done() const { return pos_ >= text_.size(); }
  [[noreturn]] void bad(const std::string& what) const {
    throw ManifestError("the manifest " + (number_ > 0 ? "(line " + std::to_string(number_) + ") " : std::string()) + what);
  }
  // "KEY VALUE": the value.
  std::string_view field(const char* key) {
    std::string_view line = next(key);
    const std::string prefix = std::string(key) + " ";
    if (line.substr(0, prefix.size()) != prefix) bad("should be \"" + std::string(key) + " ...\"");
    return line.substr(prefix.size());
  }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  int number_ = 0;
};

std::int64_t parse_int(std::string_view s, Lines& in, const char* what) {
  std::int64_t v = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  if (r.ec != std::errc() || r.ptr != s.data() + s.size()) in.bad(std::string(what) + " is not a whole number");
  return v;
}

double parse_double(std::string_view s, Lines& in, const char* what) {
  // strtod on a copy: from_chars for doubles is not in this standard library.
  const std::string copy(s);
  if (copy.empty() || copy.size() > 40) in.bad(std::string(what) + " is not a number");
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(copy.c_str(), &end);
  if (end != copy.c_str() + copy.size() || errno == ERANGE || !std::isfinite(v)) in.bad(std::string(what) + " is not a finite number");
  return v;
}

// "A B C ...": the fields split at single spaces.
std::vector<std::string_view> words(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t sp = s.find(' ', start);
    out.push_back(s.substr(start, sp == std::string_view::npos ? std::string_view::npos : sp - start));
    if (sp == std::string_view::npos) return out;
    start = sp + 1;
  }
}

void check_manifest(const Manifest& m) {
  auto need = [](bool ok, const std::string& what) {
    if (!ok) throw Error("manifest: " + what);
  };
  need(api::valid_map_name(m.map), "the map name \"" + m.map + "\" is not one ([A-Za-z0-9_.-], 1 to 64 characters)");
  need(m.version >= 1, "the version must be 1 or more");
  need(!m.parent || *m.parent >= 1, "the parent must be 1 or more");
  need(std::isfinite(m.origin.lat_deg) && std::abs(m.origin.lat_deg) <= 90 && std::isfinite(m.origin.lon_deg) &&
           std::abs(m.origin.lon_deg) <= 180 && std::isfinite(m.origin.alt_m),
       "the origin is not a latitude, longitude and altitude");
  need(std::isfinite(m.tile_size) && m.tile_size > 0 && std::isfinite(m.voxel_size) && m.voxel_size > 0,
       "the tile and voxel sizes must be positive");
  need(!m.places || api::is_hash(*m.places), "the places' hash is not a SHA-256 in lowercase hex");
  for (std::size_t i = 0; i < m.tiles.size(); ++i) {
    const ManifestTile& t = m.tiles[i];
    need(api::is_hash(t.hash), "tile " + std::to_string(t.key.tx) + "/" + std::to_string(t.key.ty) + " has no valid hash");
    need(t.points >= 0, "tile " + std::to_string(t.key.tx) + "/" + std::to_string(t.key.ty) + " has a negative point count");
    need(i == 0 || m.tiles[i - 1].key < t.key, "the tiles are not in (tx, ty) order, one a key");
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// The manifest

Manifest manifest_of(const store::Store& s, const std::string& map, std::int64_t version) {
  const auto info = s.find_map(map);
  if (!info) throw Error(s.path() + ": no map named \"" + map + "\"");
  const auto v = s.find_version(map, version);
  if (!v) throw Error(s.path() + ": map " + map + " has no version " + std::to_string(version));
  Manifest m;
  m.map = map;
  m.version = version;
  m.parent = v->parent;
  m.origin = info->origin;
  m.tile_size = info->tile_size;
  m.voxel_size = info->voxel_size;
  m.places = s.places_hash(map, version);
  for (const auto& t : s.list_tiles(map, version)) m.tiles.push_back({t.key, t.hash, t.points});
  return m;
}

std::string manifest_text(const Manifest& m) {
  check_manifest(m);
  std::string out;
  out.reserve(200 + m.tiles.size() * 90);
  out += kMagic;
  out += "\nmap " + m.map;
  out += "\nversion " + std::to_string(m.version);
  out += "\nparent " + (m.parent ? std::to_string(*m.parent) : std::string("none"));
  out += "\norigin " + format_double(m.origin.lat_deg) + " " + format_double(m.origin.lon_deg) + " " + format_double(m.origin.alt_m);
  out += "\ntile_size " + format_double(m.tile_size);
  out += "\nvoxel_size " + format_double(m.voxel_size);
  out += "\nplaces " + (m.places ? *m.places : std::string("none"));
  out += "\ntiles " + std::to_string(m.tiles.size()) + "\n";
  for (const auto& t : m.tiles) {
    out += std::to_string(t.key.tx);
    out += ' ';
    out += std::to_string(t.key.ty);
    out += ' ';
    out += t.hash;
    out += ' ';
    out += std::to_string(t.points);
    out += '\n';
  }
  return out;
}

Manifest parse_manifest_text(std::string_view text) {
  Lines in(text);
  if (text.size() > kMaxManifestBytes) in.bad("is larger than " + std::to_string(kMaxManifestBytes >> 20) + " MiB");
  if (in.next("first") != kMagic) in.bad("does not start with \"" + std::string(kMagic) + "\" (not a manifest, or a newer format)");
  Manifest m;
  m.map = std::string(in.field("map"));
  m.version = parse_int(in.field("version"), in, "the version");
  const std::string_view parent = in.field("parent");
  if (parent != "none") m.parent = parse_int(parent, in, "the parent");
  const auto origin = words(in.field("origin"));
  if (origin.size() != 3) in.bad("the origin should be three numbers: latitude, longitude, altitude");
  m.origin = GeoPoint{parse_double(origin[0], in, "the latitude"), parse_double(origin[1], in, "the longitude"),
                      parse_double(origin[2], in, "the altitude")};
  m.tile_size = parse_double(in.field("tile_size"), in, "the tile size");
  m.voxel_size = parse_double(in.field("voxel_size"), in, "the voxel size");
  const std::string_view places = in.field("places");
  if (places != "none") m.places = std::string(places);
  const std::int64_t count = parse_int(in.field("tiles"), in, "the tile count");
  // Each tile line takes at least 70 bytes: a count the text cannot hold is refused before any reserve.
  if (count < 0 || static_cast<std::uint64_t>(count) > text.size() / 70) in.bad("the tile count does not match the lines that follow");
  m.tiles.reserve(static_cast<std::size_t>(count));
  for (std::int64_t i = 0; i < count; ++i) {
    const auto w = words(in.next("tile"));
    if (w.size() != 4) in.bad("a tile line should be \"TX TY HASH POINTS\"");
    const std::int64_t tx = parse_int(w[0], in, "tx"), ty = parse_int(w[1], in, "ty");
    if (tx < INT32_MIN || tx > INT32_MAX || ty < INT32_MIN || ty > INT32_MAX) in.bad("a tile key is out of range");
    m.tiles.push_back({TileKey{static_cast<std::int32_t>(tx), static_cast<std::int32_t>(ty)}, std::string(w[2]),
                       parse_int(w[3], in, "the point count")});
  }
  if (!in.done()) in.bad("has lines after its tiles");
  try {
    if (manifest_text(m) != text) in.bad("is not in its canonical form (numbers, spaces or line ends written otherwise)");
  } catch (const ManifestError&) {
    throw;
  } catch (const Error& e) {
    in.bad(std::string("says something no store holds: ") + e.what());
  }
  return m;
}

// ---------------------------------------------------------------------------------------------
// Keys

std::string key_id(std::string_view public_key) { return store::content_hash(public_key).substr(0, 16); }

SigningKey SigningKey::generate() {
  std::unique_ptr<EVP_PKEY_CTX, void (*)(EVP_PKEY_CTX*)> ctx(EVP_PKEY_CTX_new_id(EVP_PKEY_ED25519, nullptr), &EVP_PKEY_CTX_free);
  EVP_PKEY* k = nullptr;
  if (!ctx || EVP_PKEY_keygen_init(ctx.get()) != 1 || EVP_PKEY_keygen(ctx.get(), &k) != 1)
    throw Error("cannot make an Ed25519 key: " + openssl_error());
  return SigningKey(k);
}

SigningKey SigningKey::from_seed(std::string_view seed) {
  if (seed.size() != 32) throw Error("an Ed25519 private key is 32 bytes, got " + std::to_string(seed.size()));
  EVP_PKEY* k =
      EVP_PKEY_new_raw_private_key(EVP_PKEY_ED25519, nullptr, reinterpret_cast<const unsigned char*>(seed.data()), seed.size());
  if (!k) throw Error("cannot make an Ed25519 key: " + openssl_error());
  return SigningKey(k);
}

SigningKey SigningKey::load(const std::string& pem_file) {
  const std::string pem = read_small_file(pem_file);
  Bio bio(BIO_new_mem_buf(pem.data(), static_cast<int>(pem.size())));
  EVP_PKEY* k = bio ? PEM_read_bio_PrivateKey(bio.get(), nullptr, nullptr, nullptr) : nullptr;
  if (!k) {
    ERR_clear_error();
    throw Error(pem_file + ": not a PEM private key (make one with pl-map key-gen, or openssl genpkey -algorithm ed25519)");
  }
  if (EVP_PKEY_get_id(k) != EVP_PKEY_ED25519) {
    EVP_PKEY_free(k);
    throw Error(pem_file + ": a private key, but not an Ed25519 one (maps are signed with Ed25519: pl-map key-gen makes one)");
  }
  return SigningKey(k);
}

// Delegating: the object is whole once SigningKey() returns, so should the body throw, the
// destructor frees the key.
SigningKey::SigningKey(void* evp_pkey) : SigningKey() {
  key_ = evp_pkey;
  public_key_ = raw_public_key(static_cast<EVP_PKEY*>(evp_pkey));
}

SigningKey::SigningKey(SigningKey&& o) noexcept : key_(std::exchange(o.key_, nullptr)), public_key_(std::move(o.public_key_)) {}
SigningKey& SigningKey::operator=(SigningKey&& o) noexcept {
  if (this != &o) {
    EVP_PKEY_free(static_cast<EVP_PKEY*>(key_));
    key_ = std::exchange(o.key_, nullptr);
    public_key_ = std::move(o.public_key_);
  }
  return *this;
}
SigningKey::~SigningKey() { EVP_PKEY_free(static_cast<EVP_PKEY*>(key_)); }

void SigningKey::save(const std::string& pem_file) const {
  Bio bio(BIO_new(BIO_s_mem()));
  if (!bio || PEM_write_bio_PrivateKey(bio.get(), static_cast<EVP_PKEY*>(key_), nullptr, nullptr, 0, nullptr, nullptr) != 1)
    throw Error("cannot write an Ed25519 key as PEM: " + openssl_error());
  char* data = nullptr;
  const long n = BIO_get_mem_data(bio.get(), &data);
  write_new_file(pem_file, std::string(data, static_cast<std::size_t>(n)), 0600);
}

std::string SigningKey::sign(std::string_view message) const {
  MdCtx ctx(EVP_MD_CTX_new());
  std::size_t n = kSignatureBytes;
  std::string sig(n, '\0');
  if (!ctx || EVP_DigestSignInit(ctx.get(), nullptr, nullptr, nullptr, static_cast<EVP_PKEY*>(key_)) != 1 ||
      EVP_DigestSign(ctx.get(), reinterpret_cast<unsigned char*>(sig.data()), &n, reinterpret_cast<const unsigned char*>(message.data()),
                     message.size()) != 1 ||
      n != kSignatureBytes)
    throw Error("cannot sign with Ed25519: " + openssl_error());
  return sig;
}

std::vector<std::string> load_public_keys(const std::string& pem_file) {
  const std::string pem = read_small_file(pem_file);
  Bio bio(BIO_new_mem_buf(pem.data(), static_cast<int>(pem.size())));
  std::vector<std::string> out;
  while (bio) {
    Pkey k(PEM_read_bio_PUBKEY(bio.get(), nullptr, nullptr, nullptr));
    if (!k) break;
    if (EVP_PKEY_get_id(k.get()) != EVP_PKEY_ED25519)
      throw Error(pem_file + ": public key " + std::to_string(out.size() + 1) + " is not an Ed25519 key (maps are signed with Ed25519)");
    out.push_back(raw_public_key(k.get()));
  }
  ERR_clear_error();
  // Past the last key only blank space may follow (a damaged block is not skipped silently).
  static constexpr std::string_view kEnd = "-----END PUBLIC KEY-----";
  const std::size_t end = pem.rfind(kEnd);
  std::size_t rest = 0;
  for (char c : std::string_view(pem).substr(end == std::string::npos ? 0 : end + kEnd.size()))
    rest += !std::isspace(static_cast<unsigned char>(c));
  if (out.empty() || rest > 0)
    throw Error(pem_file + (out.empty() ? ": no PEM public key in it" : ": something other than a PEM public key after key " + std::to_string(out.size())) +
                " (\"-----BEGIN PUBLIC KEY-----\" blocks of Ed25519 keys: pl-map key-gen writes one beside the private key)");
  return out;
}

std::string public_key_pem(std::string_view public_key) {
  Pkey k = public_pkey(public_key);
  Bio bio(BIO_new(BIO_s_mem()));
  if (!bio || PEM_write_bio_PUBKEY(bio.get(), k.get()) != 1) throw Error("cannot write a public key as PEM: " + openssl_error());
  char* data = nullptr;
  const long n = BIO_get_mem_data(bio.get(), &data);
  return std::string(data, static_cast<std::size_t>(n));
}

void save_public_key(std::string_view public_key, const std::string& pem_file) {
  write_new_file(pem_file, public_key_pem(public_key), 0644);
}

void sign_staged_version(store::Store& s, const std::string& map, std::int64_t version, std::string_view public_key,
                         std::string_view signature) {
  s.put_signature(map, version, public_key, signature);
  if (!verify(public_key, manifest_text(manifest_of(s, map, version)), signature))
    throw SignatureMismatch(s.path() + ": the signature of map " + map + " version " + std::to_string(version) +
                            " does not verify against its manifest as the store holds it");
}

bool verify(std::string_view public_key, std::string_view message, std::string_view signature) {
  if (public_key.size() != kPublicKeyBytes || signature.size() != kSignatureBytes) return false;
  Pkey k(EVP_PKEY_new_raw_public_key(EVP_PKEY_ED25519, nullptr, reinterpret_cast<const unsigned char*>(public_key.data()),
                                     public_key.size()));
  if (!k) {  // bytes that are no key verify nothing
    ERR_clear_error();
    return false;
  }
  MdCtx ctx(EVP_MD_CTX_new());
  if (!ctx || EVP_DigestVerifyInit(ctx.get(), nullptr, nullptr, nullptr, k.get()) != 1) throw Error("cannot verify with Ed25519: " + openssl_error());
  const int ok = EVP_DigestVerify(ctx.get(), reinterpret_cast<const unsigned char*>(signature.data()), signature.size(),
                                  reinterpret_cast<const unsigned char*>(message.data()), message.size());
  ERR_clear_error();
  return ok == 1;
}

// ---------------------------------------------------------------------------------------------
// Signed manifests

std::string signature_line(std::string_view public_key, std::string_view signature) {
  if (public_key.size() != kPublicKeyBytes || signature.size() != kSignatureBytes)
    throw Error("an Ed25519 signature line takes a 32-byte key and a 64-byte signature");
  return "signature ed25519 " + encode_base64(public_key) + " " + encode_base64(signature) + "\n";
}

VerifiedText verify_signed_text(std::string_view body, const std::vector<std::string>& trusted, std::size_t max_text_bytes,
                                const std::string& noun, const std::string& unsigned_fix, const std::string& keys) {
  if (body.size() > max_text_bytes + 256)
    throw ManifestError("the signed " + noun + " is larger than " +
                        (max_text_bytes >= (1u << 20) ? std::to_string(max_text_bytes >> 20) + " MiB" : std::to_string(max_text_bytes) + " bytes"));
  // The signature line is the last one: the text is everything before it.
  if (body.empty() || body.back() != '\n') throw ManifestError("the signed " + noun + " does not end with a line end (cut short?)");
  const std::size_t start = body.rfind('\n', body.size() - 2);
  const std::size_t line_at = start == std::string_view::npos ? 0 : start + 1;
  const std::string_view line = body.substr(line_at, body.size() - 1 - line_at);
  const auto w = words(line);
  if (w.size() != 4 || w[0] != "signature") throw ManifestError("the " + noun + " carries no signature: " + unsigned_fix);
  if (w[1] != "ed25519") throw ManifestError("the " + noun + " is signed with \"" + std::string(w[1]).substr(0, 32) + "\", not ed25519");
  const auto key = decode_base64(w[2]);
  const auto sig = decode_base64(w[3]);
  if (!key || key->size() != kPublicKeyBytes || !sig || sig->size() != kSignatureBytes)
    throw ManifestError("the " + noun + "'s signature line does not hold a 32-byte key and a 64-byte signature in base64");
  bool known = false;
  for (const auto& t : trusted) known = known || t == *key;
  if (!known)
    throw ManifestError("the " + noun + " is signed by key " + key_id(*key) + ", which is not among " + keys +
                        ": signed by someone else, or the key list is out of date");
  VerifiedText out{body.substr(0, line_at), *key};
  if (!verify(*key, out.text, *sig))
    throw ManifestError("the " + noun + "'s signature by key " + key_id(*key) +
                        " does not verify: its bytes were altered after signing (in a cache, on the network, in the store?)");
  return out;
}

SignedManifest verify_signed_manifest(std::string_view body, const std::vector<std::string>& trusted) {
  const VerifiedText v = verify_signed_text(body, trusted, kMaxManifestBytes, "manifest",
                                            "publish the version signed (pl-map publish/push --signing-key)", "the fleet's keys");
  SignedManifest out;
  out.manifest = parse_manifest_text(v.text);
  out.text = std::string(v.text);
  out.public_key = v.public_key;
  return out;
}

std::string encode_base64(std::string_view bytes) {
  std::string out(4 * ((bytes.size() + 2) / 3) + 1, '\0');
  const int n = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()), reinterpret_cast<const unsigned char*>(bytes.data()),
                                static_cast<int>(bytes.size()));
  out.resize(static_cast<std::size_t>(n));
  return out;
}

std::optional<std::string> decode_base64(std::string_view text) {
  if (text.empty() || text.size() % 4 != 0 || text.size() > (1u << 20)) return std::nullopt;
  std::size_t pad = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    const bool alpha = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '+' || c == '/';
    if (c == '=') {
      if (i + 2 < text.size()) return std::nullopt;  // padding only at the end, at most two
      ++pad;
    } else if (!alpha || pad > 0) {
      return std::nullopt;
    }
  }
  std::string out(text.size() / 4 * 3, '\0');
  const int n = EVP_DecodeBlock(reinterpret_cast<unsigned char*>(out.data()), reinterpret_cast<const unsigned char*>(text.data()),
                                static_cast<int>(text.size()));
  if (n < 0 || static_cast<std::size_t>(n) != out.size()) return std::nullopt;
  out.resize(out.size() - pad);
  // Canonical only: the bits padding leaves over must be zero (one text per byte string).
  if (encode_base64(out) != text) return std::nullopt;
  return out;
}

}  // namespace pl::signing
