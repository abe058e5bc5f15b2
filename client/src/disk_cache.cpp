#include "disk_cache.hpp"

#include "client_text.hpp"
#include "pl/common/error.hpp"

namespace pl::client {

DiskCache::DiskCache(const std::string& path, ClientStatus& status) : status_(status) {
  if (!path.empty()) cache_ = std::make_unique<TileCache>(path);
}

std::optional<CachedManifest> DiskCache::manifest(const std::string& map, std::optional<long long> version) {
  if (!cache_) return std::nullopt;
  try {
    return version ? cache_->manifest(map, *version) : cache_->last_used(map);
  } catch (const Error& e) {
    status_.problem(std::string("disk cache: ") + e.what());
    return std::nullopt;
  }
}

std::vector<CachedTile> DiskCache::rows(const std::string& map, long long version) {
  if (!cache_) return {};
  try {
    return cache_->tiles(map, version);
  } catch (const Error& e) {
    status_.problem(std::string("disk cache: ") + e.what());
    return {};
  }
}

std::optional<std::string> DiskCache::signed_manifest(const std::string& map, long long version) {
  if (!cache_) return std::nullopt;
  try {
    return cache_->signed_manifest(map, version);
  } catch (const Error& e) {
    status_.problem(std::string("disk cache: ") + e.what());
    return std::nullopt;
  }
}

std::optional<long long> DiskCache::newest_signed_version(const std::string& map) {
  if (!cache_) return std::nullopt;
  try {
    return cache_->newest_signed_version(map);
  } catch (const Error& e) {
    status_.problem(std::string("disk cache: ") + e.what());
    return std::nullopt;
  }
}

void DiskCache::put_signed_manifest(const std::string& map, long long version, std::string_view body) {
  write([&](TileCache& c) { c.put_signed_manifest(map, version, body); });
}

std::optional<std::string> DiskCache::blob(const CachedTile& t, const std::string& map, long long version) {
  if (!cache_) return std::nullopt;
  bool corrupt = false;
  std::optional<std::string> bytes;
  try {
    bytes = cache_->blob(t.hash, &corrupt);
  } catch (const Error& e) {
    status_.problem(std::string("disk cache: ") + e.what());
  }
  if (corrupt)
    status_.cache_entry_dropped("disk cache " + cache_->path() + ": tile " + key_name(t.key) + " of map " + map + " version " +
                                std::to_string(version) + " was damaged (its bytes no longer match SHA-256 " + t.hash +
                                "): dropped, fetching it again");
  if (!bytes) missing_.insert(t.hash);
  return bytes;
}

template <typename F>
void DiskCache::write(F&& f) {
  if (!cache_) return;
  try {
    f(*cache_);
  } catch (const Error& e) {
    status_.problem(std::string("disk cache: ") + e.what() + " (going on without caching this)");
  }
}

void DiskCache::put_manifest(const CachedManifest& m) {
  write([&](TileCache& c) { c.put_manifest(m); });
}

void DiskCache::put_tiles(const std::string& map, long long version, const std::vector<CachedTile>& rows) {
  write([&](TileCache& c) { c.put_tiles(map, version, rows); });
}

void DiskCache::put_blob(const std::string& hash, std::string_view bytes) {
  write([&](TileCache& c) { c.put_blob(hash, bytes); });
  if (cache_) missing_.erase(hash);
}

}  // namespace pl::client
