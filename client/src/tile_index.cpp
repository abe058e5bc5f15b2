#include "tile_index.hpp"

#include <set>
#include <utility>

namespace pl::client {

const CachedTile* TileIndex::find(const TileKey& key) const {
  static const CachedTile kNoTile{};  // (its key is not the one asked about: a "no tile" row needs none)
  auto it = rows_.find(key);
  if (it != rows_.end()) return &it->second;
  return complete_ ? &kNoTile : nullptr;
}

void TileIndex::learn(CachedTile row) {
  if (row.exists()) {
    auto [it, inserted] = key_of_hash_.emplace(row.hash, row.key);
    if (!inserted && it->second != row.key) have_usable_ = false;
  }
  TileKey key = row.key;
  rows_[key] = std::move(row);
}

void TileIndex::clear() {
  rows_.clear();
  key_of_hash_.clear();
  have_usable_ = true;
  complete_ = false;
}

std::vector<CachedTile> rows_of_answer(std::vector<CachedTile> listed, const std::vector<TileKey>& keys, const TileIndex& index) {
  std::set<TileKey> answered;
  for (const auto& r : listed) answered.insert(r.key);
  for (const TileKey& k : keys)
    if (!answered.count(k) && !index.knows(k)) listed.push_back(CachedTile{k, {}, 0});
  return listed;
}

}  // namespace pl::client
