// The current-version statement (pl/schema/signed_current.hpp): its canonical text read back
// strictly, signed and verified with Ed25519, and the checks of its map and time a vehicle makes.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "error_of.hpp"
#include "pl/schema/signed_current.hpp"

namespace {

using pl::signing::CurrentVersion;
using pl::signing::SigningKey;
using pl::test::error_of;

const CurrentVersion kSample{"town", 7, 1'800'000'000, 1'800'000'300};

TEST(SignedCurrent, TextIsCanonicalAndReadsBackExactly) {
  const std::string text = pl::signing::current_text(kSample);
  EXPECT_EQ(text, "pointlocalization-current 1\nmap town\nversion 7\nissued 1800000000\nexpires 1800000300\n");
  EXPECT_EQ(pl::signing::parse_current_text(text), kSample);
  // Anything else is refused, naming the problem.
  auto refusal = [](const std::string& t) { return error_of([&] { pl::signing::parse_current_text(t); }); };
  EXPECT_NE(refusal("pointlocalization-manifest 1\nmap town\n").find("does not start with"), std::string::npos);
  EXPECT_NE(refusal("pointlocalization-current 1\nmap town\nversion 7\n").find("ends before its issued line"), std::string::npos);
  EXPECT_NE(refusal("pointlocalization-current 1\nmap town\nversion 07\nissued 1\nexpires 2\n").find("canonical"), std::string::npos);
  EXPECT_NE(refusal("pointlocalization-current 1\nmap town\nversion seven\nissued 1\nexpires 2\n").find("(line 3) the version is not a whole number"),
            std::string::npos);
  EXPECT_NE(refusal("pointlocalization-current 1\nmap town\nversion 7\nissued 5\nexpires 5\n").find("expire after"), std::string::npos);
  EXPECT_NE(refusal("pointlocalization-current 1\nmap to wn\nversion 7\nissued 1\nexpires 2\n").find("map name"), std::string::npos);
  EXPECT_NE(refusal(text + "extra 1\n").find("lines after"), std::string::npos);
  EXPECT_NE(refusal(text.substr(0, text.size() - 1)).find("no line end"), std::string::npos);
  EXPECT_NE(refusal(std::string(2000, 'a')).find("larger than"), std::string::npos);
  // A statement no server makes is not written.
  EXPECT_THROW(pl::signing::current_text({"town", 0, 1, 2}), pl::Error);
  EXPECT_THROW(pl::signing::current_text({"", 1, 1, 2}), pl::Error);
}

TEST(SignedCurrent, SignedByATrustedKeyVerifiesAndAnyChangeIsRefused) {
  const SigningKey key = SigningKey::from_seed("pointlocalization timestamp 0001");
  const SigningKey other = SigningKey::from_seed("pointlocalization timestamp 0002");
  const std::string body = pl::signing::sign_current(kSample, key);
  const auto ok = pl::signing::verify_signed_current(body, {other.public_key(), key.public_key()});
  EXPECT_EQ(ok.current, kSample);
  EXPECT_EQ(ok.public_key, key.public_key());

  auto refusal = [&](const std::string& b, const std::vector<std::string>& trusted) {
    return error_of([&] { pl::signing::verify_signed_current(b, trusted); });
  };
  EXPECT_NE(refusal(body, {other.public_key()}).find("not among the vehicle's timestamp keys"), std::string::npos);
  // Every single byte of the text changed: refused (by the signature, or before it by the parser).
  const std::size_t text_bytes = pl::signing::current_text(kSample).size();
  for (std::size_t i = 0; i < text_bytes; ++i) {
    std::string altered = body;
    altered[i] = static_cast<char>(altered[i] ^ 0x01);
    EXPECT_THROW(pl::signing::verify_signed_current(altered, {key.public_key()}), pl::signing::ManifestError) << "byte " << i;
  }
  std::string newer = body;
  newer.replace(newer.find("version 7"), 9, "version 8");
  EXPECT_NE(refusal(newer, {key.public_key()}).find("does not verify"), std::string::npos);
  EXPECT_NE(refusal(pl::signing::current_text(kSample), {key.public_key()}).find("carries no signature: start pl-server with --timestamp-key"),
            std::string::npos);
  // A signed manifest's signature line does not make a manifest a statement.
  pl::signing::Manifest m;
  m.map = "town";
  m.version = 7;
  m.tile_size = 20;
  m.voxel_size = 0.2;
  const std::string manifest = pl::signing::manifest_text(m);
  EXPECT_NE(refusal(manifest + pl::signing::signature_line(key.public_key(), key.sign(manifest)), {key.public_key()}).find("does not start with"),
            std::string::npos);
}

TEST(SignedCurrent, UsedOnlyForItsMapAndWithinItsTime) {
  const std::int64_t issued = kSample.issued, expires = kSample.expires;
  EXPECT_NO_THROW(pl::signing::check_current(kSample, "town", issued, 0));
  EXPECT_NO_THROW(pl::signing::check_current(kSample, "town", expires, 0));
  EXPECT_NO_THROW(pl::signing::check_current(kSample, "town", expires + 60, 60));  // the clocks may disagree this much
  EXPECT_NO_THROW(pl::signing::check_current(kSample, "town", issued - 60, 60));
  auto refusal = [](const std::string& map, std::int64_t now, std::int64_t skew) {
    return error_of([&] { pl::signing::check_current(kSample, map, now, skew); });
  };
  const std::string late = refusal("town", expires + 61, 60);
  EXPECT_NE(late.find("expired at 2027-01-15 08:05:00 UTC"), std::string::npos) << late;
  EXPECT_NE(late.find("may hide a newer version"), std::string::npos) << late;
  const std::string early = refusal("town", issued - 61, 60);
  EXPECT_NE(early.find("later than this vehicle's clock"), std::string::npos) << early;
  EXPECT_NE(early.find("set the vehicle's clock"), std::string::npos) << early;
  EXPECT_NE(refusal("city", issued, 60).find("is map town's, not city's"), std::string::npos);
}

}  // namespace
