// Signed maps (pl/schema/signed_manifest.hpp): the manifest's canonical text, Ed25519 keys and
// signatures through OpenSSL, PEM key files, and the signatures the store keeps, on both engines.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>
#include <string>
#include <vector>

#include "error_of.hpp"
#include "pl/common/error.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"
#include "store_backends.hpp"
#include "store_test_util.hpp"
#include "test_util.hpp"

namespace {

using pl::signing::Manifest;
using pl::signing::ManifestError;
using pl::signing::SigningKey;
using pl::store::Store;
using pl::store::VersionState;
using pl::test::put_cell;

const pl::GeoPoint kOrigin{48.137154, 11.576124, 519.25};

Manifest sample() {
  Manifest m;
  m.map = "town";
  m.version = 3;
  m.parent = 2;
  m.origin = kOrigin;
  m.tile_size = 20;
  m.voxel_size = 0.2;
  m.places = pl::store::content_hash("places");
  m.tiles = {{{-1, 0}, pl::store::content_hash("a"), 1200}, {{-1, 5}, pl::store::content_hash("b"), 0}, {{0, -3}, pl::store::content_hash("c"), 7}};
  return m;
}

TEST(SignedManifest, TextIsCanonicalAndReadsBackExactly) {
  const Manifest m = sample();
  const std::string text = pl::signing::manifest_text(m);
  EXPECT_EQ(text.rfind("pointlocalization-manifest 1\nmap town\nversion 3\nparent 2\norigin ", 0), 0u) << text;
  EXPECT_NE(text.find("\ntiles 3\n-1 0 " + m.tiles[0].hash + " 1200\n"), std::string::npos) << text;
  const Manifest back = pl::signing::parse_manifest_text(text);
  EXPECT_EQ(back.map, m.map);
  EXPECT_EQ(back.version, 3);
  EXPECT_EQ(back.parent, 2);
  EXPECT_EQ(back.origin.lat_deg, m.origin.lat_deg);  // exactly: %.17g reads back bit for bit
  EXPECT_EQ(back.origin.lon_deg, m.origin.lon_deg);
  EXPECT_EQ(back.origin.alt_m, m.origin.alt_m);
  EXPECT_EQ(back.voxel_size, 0.2);
  EXPECT_EQ(back.places, m.places);
  EXPECT_EQ(back.tiles, m.tiles);
  EXPECT_EQ(pl::signing::manifest_text(back), text);

  Manifest none = m;
  none.parent.reset();
  none.places.reset();
  none.tiles.clear();
  const std::string empty = pl::signing::manifest_text(none);
  EXPECT_NE(empty.find("\nparent none\n"), std::string::npos);
  EXPECT_NE(empty.find("\nplaces none\ntiles 0\n"), std::string::npos);
  EXPECT_EQ(pl::signing::parse_manifest_text(empty).tiles.size(), 0u);
}

TEST(SignedManifest, TextThatIsNotExactlyCanonicalIsRefusedNamingTheLine) {
  const std::string text = pl::signing::manifest_text(sample());
  auto refused = [](const std::string& t) { return pl::test::error_of([&] { pl::signing::parse_manifest_text(t); }); };
  auto replaced = [&](const std::string& from, const std::string& to) {
    std::string t = text;
    const auto at = t.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return t.replace(at, from.size(), to);
  };
  EXPECT_NE(refused(replaced("version 3", "version 03")).find("canonical"), std::string::npos);
  EXPECT_NE(refused(replaced("tile_size 20", "tile_size 20.0")).find("canonical"), std::string::npos);
  EXPECT_NE(refused(replaced("\n", "\r\n")).find("line 1"), std::string::npos);
  EXPECT_NE(refused(replaced("tiles 3", "tiles 4")).find("tile"), std::string::npos);
  EXPECT_NE(refused(replaced("tiles 3", "tiles 99999999999")).find("tile count"), std::string::npos);
  EXPECT_NE(refused(text + "extra\n").find("lines after its tiles"), std::string::npos);
  EXPECT_NE(refused(text.substr(0, text.size() - 1)).find("no line end"), std::string::npos);
  EXPECT_NE(refused("pointlocalization-manifest 2\n").find("newer format"), std::string::npos);
  EXPECT_NE(refused(replaced("map town", "map to/wn")).find("map name"), std::string::npos);
  // Tiles out of order or twice at a key: no store lists them so.
  const Manifest m = sample();
  std::string swapped = text;
  const std::string l0 = "-1 0 " + m.tiles[0].hash + " 1200\n", l1 = "-1 5 " + m.tiles[1].hash + " 0\n";
  swapped.replace(swapped.find(l0), l0.size() + l1.size(), l1 + l0);
  EXPECT_NE(refused(swapped).find("order"), std::string::npos);
  EXPECT_NE(refused(replaced(m.tiles[1].hash, "XYZ")).find("hash"), std::string::npos);
  EXPECT_NE(refused(replaced(" 1200\n", " -1200\n")).find("negative"), std::string::npos);
  EXPECT_NE(refused(replaced(" 1200\n", " 12a\n")).find("point count"), std::string::npos);
}

TEST(SignedManifest, SignedByTheFleetKeyVerifiesAndAnyChangedByteDoesNot) {
  const SigningKey key = SigningKey::generate(), other = SigningKey::generate();
  ASSERT_EQ(key.public_key().size(), 32u);
  EXPECT_NE(key.public_key(), other.public_key());
  const std::string text = pl::signing::manifest_text(sample());
  const std::string body = text + pl::signing::signature_line(key.public_key(), key.sign(text));
  const auto ok = pl::signing::verify_signed_manifest(body, {other.public_key(), key.public_key()});
  EXPECT_EQ(ok.text, text);
  EXPECT_EQ(ok.public_key, key.public_key());
  EXPECT_EQ(ok.manifest.tiles, sample().tiles);

  // Not among the trusted keys; no signature at all; every single byte of the text flipped.
  EXPECT_NE(pl::test::error_of([&] { pl::signing::verify_signed_manifest(body, {other.public_key()}); }).find("not among the fleet's keys"),
            std::string::npos);
  EXPECT_NE(pl::test::error_of([&] { pl::signing::verify_signed_manifest(text, {key.public_key()}); }).find("no signature"), std::string::npos);
  int refused = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    std::string t = body;
    t[i] = static_cast<char>(t[i] ^ 0x01);
    try {
      pl::signing::verify_signed_manifest(t, {key.public_key()});
    } catch (const ManifestError&) {
      ++refused;
    }
  }
  EXPECT_EQ(refused, static_cast<int>(text.size()));
  // A signature of other bytes, and the right signature under another key's name.
  const std::string forged = text + pl::signing::signature_line(key.public_key(), key.sign(text + " "));
  EXPECT_NE(pl::test::error_of([&] { pl::signing::verify_signed_manifest(forged, {key.public_key()}); }).find("does not verify"), std::string::npos);
  const std::string renamed = text + pl::signing::signature_line(other.public_key(), key.sign(text));
  EXPECT_THROW(pl::signing::verify_signed_manifest(renamed, {other.public_key()}), ManifestError);
  // Keys from a fixed seed are the same key every time (the fuzz seeds' fleet key).
  const std::string seed(32, '\x07');
  EXPECT_EQ(SigningKey::from_seed(seed).public_key(), SigningKey::from_seed(seed).public_key());
  EXPECT_THROW(SigningKey::from_seed("short"), pl::Error);
}

// RFC 8032 section 7.1's Ed25519 test vectors 1-3: our keys, signatures and verification against
// the standard's own bytes, not only against our own output.
TEST(SignedManifest, Rfc8032TestVectors) {
  struct Vector {
    const char *seed, *public_key, *message, *signature;
  };
  const Vector vectors[] = {
      {"9d61b19deffd5a60ba844af492ec2cc44449c5697b326919703bac031cae7f60",
       "d75a980182b10ab7d54bfed3c964073a0ee172f3daa62325af021a68f707511a", "",
       "e5564300c360ac729086e2cc806e828a84877f1eb8e5d974d873e06522490155"
       "5fb8821590a33bacc61e39701cf9b46bd25bf5f0595bbe24655141438e7a100b"},
      {"4ccd089b28ff96da9db6c346ec114e0f5b8a319f35aba624da8cf6ed4fb8a6fb",
       "3d4017c3e843895a92b70aa74d1b7ebc9c982ccf2ec4968cc0cd55f12af4660c", "72",
       "92a009a9f0d4cab8720e820b5f642540a2b27b5416503f8fb3762223ebdb69da"
       "085ac1e43e15996e458f3613d0f11d8c387b2eaeb4302aeeb00d291612bb0c00"},
      {"c5aa8df43f9f837bedb7442f31dcb7b166d38535076f094b85ce3a2e0b4458f7",
       "fc51cd8e6218a1a38da47ed00230f0580816ed13ba3303ac5deb911548908025", "af82",
       "6291d657deec24024827e69c3abe01a30ce548a284743a445e3680d7db5ac3ac"
       "18ff9b538d16f290ae67f760984dc6594a7c15e9716ed28dc027beceea1ec40a"},
  };
  for (const Vector& v : vectors) {
    const std::string public_key = pl::test::from_hex(v.public_key), message = pl::test::from_hex(v.message),
                      signature = pl::test::from_hex(v.signature);
    const SigningKey key = SigningKey::from_seed(pl::test::from_hex(v.seed));
    EXPECT_EQ(key.public_key(), public_key) << v.seed;
    EXPECT_EQ(key.sign(message), signature) << v.seed;
    EXPECT_TRUE(pl::signing::verify(public_key, message, signature)) << v.seed;
    std::string flipped = signature;
    flipped[63] = static_cast<char>(flipped[63] ^ 0x01);
    EXPECT_FALSE(pl::signing::verify(public_key, message, flipped)) << v.seed;
  }
}

// openssl's own pkeyutl verifies what we sign, and we verify what it signs, over the same files.
TEST(SignedManifest, OpensslVerifiesOurSignaturesAndWeVerifyItsOwn) {
  pl::test::TempDir dir;
  const SigningKey ours = SigningKey::generate();
  ours.save(dir / "ours.key");
  pl::signing::save_public_key(ours.public_key(), dir / "ours.pub");
  const std::string text = pl::signing::manifest_text(sample());
  pl::test::write_file(dir / "manifest.txt", text);
  std::ofstream(dir / "ours.sig", std::ios::binary) << ours.sign(text);
  const std::string verify =
      "openssl pkeyutl -verify -pubin -inkey " + dir / "ours.pub" + " -rawin -in " + dir / "manifest.txt" + " -sigfile ";
  auto r = pl::test::run(verify + dir / "ours.sig");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("Signature Verified Successfully"), std::string::npos) << r.output;
  std::ofstream(dir / "other.sig", std::ios::binary) << ours.sign(text + " ");
  EXPECT_NE(pl::test::run(verify + dir / "other.sig").exit_code, 0) << "openssl took a signature of other bytes";

  ASSERT_EQ(pl::test::run("openssl genpkey -algorithm ed25519 -out " + dir / "theirs.key").exit_code, 0);
  r = pl::test::run("openssl pkeyutl -sign -inkey " + dir / "theirs.key" + " -rawin -in " + dir / "manifest.txt" + " -out " +
                    dir / "theirs.sig");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string theirs = SigningKey::load(dir / "theirs.key").public_key(),
                    signature = pl::test::read_file(dir / "theirs.sig");
  ASSERT_EQ(signature.size(), 64u);
  EXPECT_TRUE(pl::signing::verify(theirs, text, signature));
  EXPECT_FALSE(pl::signing::verify(theirs, text + " ", signature));
}

TEST(SignedManifest, KeyFilesArePemThatOpensslWritesAndReads) {
  pl::test::TempDir dir;
  const SigningKey key = SigningKey::generate();
  key.save(dir / "fleet.key");
  struct stat st {};
  ASSERT_EQ(::stat((dir / "fleet.key").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);  // the private key: its owner's only
  EXPECT_NE(pl::test::error_of([&] { key.save(dir / "fleet.key"); }).find("never written over"), std::string::npos);
  const SigningKey loaded = SigningKey::load(dir / "fleet.key");
  EXPECT_EQ(loaded.public_key(), key.public_key());
  const std::string text = "anything";
  EXPECT_TRUE(pl::signing::verify(key.public_key(), text, loaded.sign(text)));
  EXPECT_FALSE(pl::signing::verify(key.public_key(), text + ".", loaded.sign(text)));
  EXPECT_FALSE(pl::signing::verify(std::string(32, '\0'), text, loaded.sign(text)));
  EXPECT_FALSE(pl::signing::verify("short", text, loaded.sign(text)));

  // The public key: one file may hold several (a fleet moving to a new key).
  pl::signing::save_public_key(key.public_key(), dir / "fleet.pub");
  EXPECT_EQ(pl::signing::load_public_keys(dir / "fleet.pub"), std::vector<std::string>{key.public_key()});
  const SigningKey next = SigningKey::generate();
  pl::test::write_file(dir / "both.pub", pl::signing::public_key_pem(key.public_key()) + "\n" + pl::signing::public_key_pem(next.public_key()));
  EXPECT_EQ(pl::signing::load_public_keys(dir / "both.pub"), (std::vector<std::string>{key.public_key(), next.public_key()}));
  // openssl's own tools read what we write, and we read what they write.
  auto r = pl::test::run("openssl pkey -in " + dir / "fleet.key" + " -pubout 2>&1");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output, pl::signing::public_key_pem(key.public_key()));
  ASSERT_EQ(pl::test::run("openssl genpkey -algorithm ed25519 -out " + dir / "openssl.key" + " 2>&1").exit_code, 0);
  const SigningKey theirs = SigningKey::load(dir / "openssl.key");
  EXPECT_EQ(theirs.public_key().size(), 32u);

  // Files that are not what they should be: the file and the fix named.
  pl::test::write_file(dir / "junk.pub", "not a key\n");
  EXPECT_NE(pl::test::error_of([&] { pl::signing::load_public_keys(dir / "junk.pub"); }).find("junk.pub: no PEM public key"), std::string::npos);
  pl::test::write_file(dir / "tail.pub", pl::signing::public_key_pem(key.public_key()) + "-----BEGIN PUBLIC KEY-----\nAAAA\n");
  EXPECT_NE(pl::test::error_of([&] { pl::signing::load_public_keys(dir / "tail.pub"); }).find("after key 1"), std::string::npos);
  ASSERT_EQ(pl::test::run("openssl genpkey -algorithm ec -pkeyopt ec_paramgen_curve:P-256 -out " + dir / "ec.key" + " 2>&1").exit_code, 0);
  EXPECT_NE(pl::test::error_of([&] { SigningKey::load(dir / "ec.key"); }).find("not an Ed25519 one"), std::string::npos);
  EXPECT_NE(pl::test::error_of([&] { SigningKey::load(dir / "fleet.pub"); }).find("not a PEM private key"), std::string::npos);
  EXPECT_NE(pl::test::error_of([&] { SigningKey::load(dir / "missing.key"); }).find("cannot open"), std::string::npos);
}

TEST(SignedManifest, Base64IsStrictAndCanonical) {
  for (const std::string& s : {std::string(), std::string("f"), std::string("fo"), std::string("foo"), std::string(32, '\xff')}) {
    if (s.empty()) continue;
    EXPECT_EQ(pl::signing::decode_base64(pl::signing::encode_base64(s)), s);
  }
  EXPECT_EQ(pl::signing::encode_base64("foob"), "Zm9vYg==");
  EXPECT_FALSE(pl::signing::decode_base64("Zm9vYh=="));  // non-zero bits under the padding: not canonical
  EXPECT_FALSE(pl::signing::decode_base64("Zm9v Yg=="));
  EXPECT_FALSE(pl::signing::decode_base64("Zm=vYg=="));
  EXPECT_FALSE(pl::signing::decode_base64("Zm9vYg="));
  EXPECT_FALSE(pl::signing::decode_base64(""));
}

// ---- the store's signatures, on both engines

using StoreSignatureTest = pl::test::BackendTest;
PL_BOTH_BACKENDS(StoreSignatureTest);

TEST_P(StoreSignatureTest, AVersionIsSignedWhileStagedAndTheSignatureStaysWithIt) {
  Store s = Store::open(path);
  s.create_map("town", kOrigin, 20, 0.2);
  s.create_version("town", std::nullopt, "");
  put_cell(s, "town", 1, 0, 0, 1);
  put_cell(s, "town", 1, -1, 2, 2);
  s.put_places("town", 1, "places");
  EXPECT_FALSE(s.signature("town", 1));
  const SigningKey key = SigningKey::generate();
  const Manifest m = pl::signing::manifest_of(s, "town", 1);
  EXPECT_EQ(m.tiles.size(), 2u);
  EXPECT_EQ(m.places, pl::store::content_hash("places"));
  EXPECT_FALSE(m.parent);
  const std::string text = pl::signing::manifest_text(m);
  {
    Store::Transaction tx(s);
    s.put_signature("town", 1, key.public_key(), key.sign(text));
    s.publish("town", 1);
    tx.commit();
  }
  const auto sig = s.signature("town", 1);
  ASSERT_TRUE(sig);
  EXPECT_EQ(sig->public_key, key.public_key());
  EXPECT_TRUE(pl::signing::verify(sig->public_key, pl::signing::manifest_text(pl::signing::manifest_of(s, "town", 1)), sig->signature));
  EXPECT_EQ(sig->signed_at.size(), 24u) << sig->signed_at;  // 2024-05-01T10:11:12.345Z

  // Published: read-only, through the store and under it (the triggers).
  EXPECT_NE(pl::test::error_of([&] { s.put_signature("town", 1, key.public_key(), key.sign("other")); }).find("is published"), std::string::npos);
  EXPECT_NE(raw_exec("UPDATE signatures SET signed = signed"), "");
  EXPECT_NE(raw_exec("DELETE FROM signatures"), "");
  // Arguments of the wrong size are refused before the engine.
  s.create_version("town", std::nullopt, "");
  EXPECT_NE(pl::test::error_of([&] { s.put_signature("town", 2, "short", key.sign(text)); }).find("32-byte public key"), std::string::npos);
  EXPECT_NE(pl::test::error_of([&] { s.put_signature("nowhere", 1, key.public_key(), key.sign(text)); }).find("unknown map"), std::string::npos);
  // A new version does not inherit its parent's signature; its manifest names the parent.
  EXPECT_FALSE(s.signature("town", 2));
  EXPECT_EQ(pl::signing::manifest_of(s, "town", 2).parent, 1);
  s.put_signature("town", 2, key.public_key(), key.sign("first"));
  s.put_signature("town", 2, key.public_key(), key.sign("second"));  // replaced while staged
  EXPECT_EQ(s.signature("town", 2)->signature, key.sign("second"));
  EXPECT_EQ(raw_scalar("SELECT count(*) FROM signatures"), 2);
  EXPECT_FALSE(s.signature("town", 9));
  EXPECT_FALSE(s.signature("nowhere", 1));
  EXPECT_TRUE(s.integrity_ok());
  EXPECT_THROW(pl::signing::manifest_of(s, "town", 9), pl::Error);
}

}  // namespace
