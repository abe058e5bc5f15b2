// Fuzz target: ROS 1 bag bytes as open_ros1 sees them (a recording from a robot: cut short by a
// power loss, damaged on a disk, or written by a tool with its own ideas). Refusing with pl::Error is
// the reader's job; a bag that opens must be consistent: every topic ROS 1 encoded, the topics'
// counts adding up to the messages listed, each message on a listed topic, in time order, and each
// one readable, in any order, with exactly the bytes its reference promises.
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/recordings/bag.hpp"

namespace {

// Reads every message, first to last; the bytes' hashes, to compare with another pass.
std::vector<std::size_t> read_all(pl::bag::Reader& r) {
  std::vector<std::size_t> hashes;
  for (const auto& m : r.messages()) {
    const std::string_view v = r.read(m);
    if (v.size() != m.size) std::abort();
    hashes.push_back(std::hash<std::string_view>{}(v));
  }
  return hashes;
}

void check(pl::bag::Reader& r) {
  std::size_t counted = 0;
  for (const auto& t : r.topics()) {
    if (t.encoding != pl::bag::Encoding::Ros1) std::abort();
    counted += t.count;
  }
  if (counted != r.messages().size()) std::abort();
  const auto& ms = r.messages();
  for (std::size_t i = 0; i < ms.size(); ++i) {
    if (ms[i].topic >= r.topics().size()) std::abort();
    if (i > 0 && ms[i].time_ns < ms[i - 1].time_ns) std::abort();
  }
  // Every listed message was found in a chunk that decompressed when the bag was opened, so
  // reading it cannot fail: a pl::Error here is an inconsistency too.
  const std::vector<std::size_t> forward = read_all(r);
  // Backwards, which makes a compressed bag decompress its chunks again (the reader keeps one):
  // the same bytes must come back.
  for (std::size_t i = ms.size(); i-- > 0;)
    if (std::hash<std::string_view>{}(r.read(ms[i])) != forward[i]) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::unique_ptr<pl::bag::Reader> reader;
  try {
    reader = pl::bag::open_ros1(pl::bag::hold_bytes(std::string(reinterpret_cast<const char*>(data), size), "fuzz.bag"));
  } catch (const pl::Error&) {
    return 0;
  }
  try {
    check(*reader);
  } catch (const pl::Error&) {
    std::abort();
  }
  return 0;
}
