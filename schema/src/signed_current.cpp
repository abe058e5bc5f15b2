// The current-version statement (pl/schema/signed_current.hpp).
#include "pl/schema/signed_current.hpp"

#include <charconv>
#include <chrono>
#include <ctime>

#include "pl/schema/api_rules.hpp"

namespace pl::signing {

namespace {

constexpr std::string_view kMagic = "pointlocalization-current 1";

[[noreturn]] void bad(int line, const std::string& what) {
  throw ManifestError("the current-version statement " + (line > 0 ? "(line " + std::to_string(line) + ") " : std::string()) + what);
}

// A Unix time as people read it, for messages: "2026-12-05 19:30:00 UTC".
std::string utc(std::int64_t t) {
  const std::time_t tt = static_cast<std::time_t>(t);
  std::tm tm{};
  if (!gmtime_r(&tt, &tm)) return std::to_string(t);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%d %H:%M:%S UTC", &tm);
  return buf;
}

}  // namespace

std::string current_text(const CurrentVersion& c) {
  if (!api::valid_map_name(c.map)) throw Error("current-version statement: the map name \"" + c.map + "\" is not one ([A-Za-z0-9_.-], 1 to 64 characters)");
  if (c.version < 1) throw Error("current-version statement: the version must be 1 or more");
  if (c.expires <= c.issued) throw Error("current-version statement: it must expire after it is issued");
  return std::string(kMagic) + "\nmap " + c.map + "\nversion " + std::to_string(c.version) + "\nissued " + std::to_string(c.issued) +
         "\nexpires " + std::to_string(c.expires) + "\n";
}

CurrentVersion parse_current_text(std::string_view text) {
  if (text.size() > kMaxCurrentBytes) bad(0, "is larger than " + std::to_string(kMaxCurrentBytes) + " bytes");
  std::size_t pos = 0;
  int number = 0;
  auto next = [&](const char* what) {
    if (pos >= text.size()) bad(number, "ends before its " + std::string(what) + " line");
    const std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) bad(number + 1, "has no line end");
    const std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++number;
    return line;
  };
  auto field = [&](const char* key) {
    const std::string_view line = next(key);
    const std::string prefix = std::string(key) + " ";
    if (line.substr(0, prefix.size()) != prefix) bad(number, "should be \"" + std::string(key) + " ...\"");
    return line.substr(prefix.size());
  };
  auto integer = [&](std::string_view s, const char* what) {
    std::int64_t v = 0;
    const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
    if (r.ec != std::errc() || r.ptr != s.data() + s.size()) bad(number, std::string(what) + " is not a whole number");
    return v;
  };
  if (next("first") != kMagic) bad(1, "does not start with \"" + std::string(kMagic) + "\" (not a statement, or a newer format)");
  CurrentVersion c;
  c.map = std::string(field("map"));
  c.version = integer(field("version"), "the version");
  c.issued = integer(field("issued"), "the issue time");
  c.expires = integer(field("expires"), "the expiry");
  if (pos != text.size()) bad(number, "has lines after its expiry");
  try {
    if (current_text(c) != text) bad(0, "is not in its canonical form (numbers or spaces written otherwise)");
  } catch (const ManifestError&) {
    throw;
  } catch (const Error& e) {
    bad(0, std::string("says something no server says: ") + e.what());
  }
  return c;
}

std::string sign_current(const CurrentVersion& c, const SigningKey& key) {
  std::string text = current_text(c);
  return text + signature_line(key.public_key(), key.sign(text));
}

SignedCurrent verify_signed_current(std::string_view body, const std::vector<std::string>& trusted) {
  const VerifiedText v = verify_signed_text(body, trusted, kMaxCurrentBytes, "current-version statement",
                                            "start pl-server with --timestamp-key, or point the vehicle at a server that has one",
                                            "the vehicle's timestamp keys");
  return SignedCurrent{parse_current_text(v.text), v.public_key};
}

void check_current(const CurrentVersion& c, const std::string& map, std::int64_t now, std::int64_t skew_s) {
  if (c.map != map) bad(0, "is map " + c.map + "'s, not " + map + "'s (an answer for another map, replayed)");
  if (c.issued > now + skew_s)
    bad(0, "was issued at " + utc(c.issued) + ", later than this vehicle's clock (" + utc(now) +
               ") allows: set the vehicle's clock (or the server's)");
  if (c.expires < now - skew_s)
    bad(0, "expired at " + utc(c.expires) + " (this vehicle's clock: " + utc(now) +
               "): an old answer, kept by a cache or replayed by the network, that may hide a newer version; or a clock that is wrong");
}

std::int64_t unix_now() {
  return std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace pl::signing
