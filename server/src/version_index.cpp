#include "version_index.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <deque>
#include <map>
#include <mutex>
#include <shared_mutex>
#include <utility>

namespace pl::server {

VersionIndex::VersionIndex(double tile_size, const std::vector<store::TileRecord>& tiles) : tile_size_(tile_size) {
  tiles_.reserve(tiles.size());
  for (const auto& t : tiles) tiles_.push_back({t.key, t.hash, t.points, t.bytes});
  for (std::size_t i = 0; i < tiles.size(); ++i) {
    const auto& t = tiles[i];
    totals_.points += t.points;
    totals_.bytes += t.bytes;
    const double lo[3] = {t.min_x, t.min_y, t.min_z}, hi[3] = {t.max_x, t.max_y, t.max_z};
    for (int a = 0; a < 3; ++a) {
      totals_.min[a] = i == 0 ? lo[a] : std::min(totals_.min[a], lo[a]);
      totals_.max[a] = i == 0 ? hi[a] : std::max(totals_.max[a], hi[a]);
    }
  }
  std::sort(tiles_.begin(), tiles_.end(), [](const Tile& a, const Tile& b) { return a.key < b.key; });
  by_key_.reserve(tiles_.size());
  for (std::size_t i = 0; i < tiles_.size(); ++i) by_key_.emplace(pack(tiles_[i].key), static_cast<std::uint32_t>(i));
}

std::vector<const VersionIndex::Tile*> VersionIndex::in_disc(double x, double y, double radius) const {
  std::vector<const Tile*> out;
  if (!(radius >= 0.0) || !std::isfinite(x) || !std::isfinite(y) || tiles_.empty()) return out;
  const TileGrid grid(tile_size_);
  const double r2 = radius * radius;
  const auto near = [&](const TileKey& k) {
    const TileBounds b = grid.bounds_of(k);
    const double dx = std::max({b.min_x - x, 0.0, x - b.max_x}), dy = std::max({b.min_y - y, 0.0, y - b.max_y});
    return dx * dx + dy * dy <= r2;
  };
  // The disc's keys, counted in doubles: far from the origin or with small tiles they need not fit
  // an int32, and then the version's own tiles are fewer anyway.
  // The key below the disc's edge too: a square is closed on its far side for this test, so the
  // tile ending exactly radius away (x - radius on its edge) touches the disc.
  const double lo_x = std::floor((x - radius) / tile_size_) - 1, hi_x = std::floor((x + radius) / tile_size_);
  const double lo_y = std::floor((y - radius) / tile_size_) - 1, hi_y = std::floor((y + radius) / tile_size_);
  const double keys = (hi_x - lo_x + 1) * (hi_y - lo_y + 1);
  if (keys > static_cast<double>(tiles_.size()) || lo_x < INT32_MIN || hi_x > INT32_MAX || lo_y < INT32_MIN || hi_y > INT32_MAX) {
    for (const Tile& t : tiles_)
      if (near(t.key)) out.push_back(&t);
    return out;
  }
  for (auto tx = static_cast<std::int64_t>(lo_x); tx <= static_cast<std::int64_t>(hi_x); ++tx)
    for (auto ty = static_cast<std::int64_t>(lo_y); ty <= static_cast<std::int64_t>(hi_y); ++ty) {
      const TileKey k{static_cast<std::int32_t>(tx), static_cast<std::int32_t>(ty)};
      const auto it = by_key_.find(pack(k));
      if (it != by_key_.end() && near(k)) out.push_back(&tiles_[it->second]);
    }
  return out;
}

namespace {
// Appends an integer's decimal digits (std::to_string would allocate a string per number: five per
// tile were a tenth of an ROI query's time).
void append_int(std::string& out, std::int64_t v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  out.append(buf, r.ptr);
}
}  // namespace

std::string roi_body(const std::string& map, std::int64_t version, double tile_size, const std::vector<const VersionIndex::Tile*>& tiles,
                     const std::vector<std::string_view>& drop) {
  // The url's fixed part, escaped as nlohmann::json escapes a string, without its closing quote.
  std::string url = nlohmann::json("/v1/maps/" + map + "/versions/" + std::to_string(version) + "/tiles/")
                        .dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  url.pop_back();
  std::string out;
  out.reserve(64 + tiles.size() * (160 + url.size()) + drop.size() * 68);
  out += "{\"drop\":[";
  for (std::size_t i = 0; i < drop.size(); ++i) {
    if (i) out += ',';
    out += '"';
    out += drop[i];
    out += '"';
  }
  out += "],\"tile_size\":";
  out += nlohmann::json(tile_size).dump();
  out += ",\"tiles\":[";
  for (std::size_t i = 0; i < tiles.size(); ++i) {
    const VersionIndex::Tile& t = *tiles[i];
    if (i) out += ',';
    out += "{\"bytes\":";
    append_int(out, t.bytes);
    out += ",\"hash\":\"";
    out += t.hash;
    out += "\",\"points\":";
    append_int(out, t.points);
    out += ",\"tx\":";
    append_int(out, t.key.tx);
    out += ",\"ty\":";
    append_int(out, t.key.ty);
    out += ",\"url\":";
    out += url;
    append_int(out, t.key.tx);
    out += '/';
    append_int(out, t.key.ty);
    out += "\"}";
  }
  out += "],\"version\":";
  append_int(out, version);
  out += "}\n";
  return out;
}

struct VersionIndexCache::Impl {
  mutable std::shared_mutex mutex;
  std::map<std::pair<std::string, std::int64_t>, std::shared_ptr<const VersionIndex>> indexes;
  std::deque<std::pair<std::string, std::int64_t>> order;  // oldest first
};

VersionIndexCache::VersionIndexCache(std::size_t capacity) : capacity_(capacity), impl_(std::make_shared<Impl>()) {}

std::shared_ptr<const VersionIndex> VersionIndexCache::find(const std::string& map, std::int64_t version) const {
  std::shared_lock lock(impl_->mutex);
  const auto it = impl_->indexes.find({map, version});
  return it == impl_->indexes.end() ? nullptr : it->second;
}

void VersionIndexCache::put(const std::string& map, std::int64_t version, std::shared_ptr<const VersionIndex> index) {
  if (capacity_ == 0) return;
  std::unique_lock lock(impl_->mutex);
  if (!impl_->indexes.emplace(std::pair{map, version}, std::move(index)).second) return;
  impl_->order.emplace_back(map, version);
  while (impl_->order.size() > capacity_) {
    impl_->indexes.erase(impl_->order.front());
    impl_->order.pop_front();
  }
}

}  // namespace pl::server
