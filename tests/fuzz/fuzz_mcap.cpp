// Fuzz target: MCAP bytes as pl::bag::open_mcap sees them (a recording from anywhere: a robot that
// crashed mid-write, a damaged disk, a hostile upload). Refusing with pl::Error is the reader's job;
// a file that opens must be consistent: every listed message on a listed topic, the messages in time
// order, the topics' counts adding up to them, and every message readable (open checked every chunk
// already, so read() may not refuse one) with the size listed, the same bytes forwards and backwards
// (read() keeps the last chunk it decompressed: reading in another order must not change a byte).
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/recordings/bag.hpp"

namespace {

std::uint64_t fnv1a(std::string_view s) {
  std::uint64_t h = 1469598103934665603ull;
  for (char c : s) h = (h ^ static_cast<unsigned char>(c)) * 1099511628211ull;
  return h;
}

void check(pl::bag::Reader& r) {
  if (std::string_view(r.format()) != "MCAP" || r.path() != "fuzz.mcap") std::abort();
  const auto& topics = r.topics();
  const auto& messages = r.messages();
  std::vector<std::size_t> counts(topics.size(), 0);
  for (std::size_t i = 0; i < messages.size(); ++i) {
    const auto& m = messages[i];
    if (m.topic >= topics.size()) std::abort();
    ++counts[m.topic];
    if (i > 0 && m.time_ns < messages[i - 1].time_ns) std::abort();
    if (m.time_ns < 0) std::abort();  // log times are unsigned in the file
  }
  for (std::size_t t = 0; t < topics.size(); ++t)
    if (counts[t] != topics[t].count) std::abort();

  std::vector<std::uint64_t> hashes(messages.size());
  try {
    for (std::size_t i = 0; i < messages.size(); ++i) {
      const std::string_view v = r.read(messages[i]);
      if (v.size() != messages[i].size) std::abort();
      hashes[i] = fnv1a(v);
    }
    for (std::size_t i = messages.size(); i-- > 0;) {
      const std::string_view v = r.read(messages[i]);
      if (v.size() != messages[i].size || fnv1a(v) != hashes[i]) std::abort();
    }
  } catch (const pl::Error&) {
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::unique_ptr<pl::bag::Reader> reader;
  try {
    reader = pl::bag::open_mcap(pl::bag::hold_bytes(std::string(reinterpret_cast<const char*>(data), size), "fuzz.mcap"));
  } catch (const pl::Error&) {
    return 0;
  }
  check(*reader);
  return 0;
}
