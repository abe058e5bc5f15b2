// Fuzz target: the places stored with a map version, as the localizer decodes them before a
// relocalization. Refusing with pl::Error is fine; places that come back encode to the input's own
// bytes (the format has one encoding per content) and can be searched.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "pl/common/error.hpp"
#include "pl/registration/place_index.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  pl::registration::PlaceIndex index;
  try {
    index = pl::registration::PlaceIndex::decode(bytes, "fuzz.places");
  } catch (const pl::Error&) {
    return 0;
  }
  // Heights decode to multiples of 0.1 m and encode back to the same steps.
  if (index.encode() != bytes) std::abort();
  if (!index.empty()) {
    const auto& first = index.places().front();
    const auto proposals = index.propose(first.descriptor, 3);
    for (const auto& p : proposals)
      if (p.place >= index.places().size() || !p.pose.matrix().allFinite() || !(p.distance >= 0 && p.distance < 1)) std::abort();
  }
  return 0;
}
