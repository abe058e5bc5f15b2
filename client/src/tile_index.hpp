// The tile client's index of the pinned map version: each known key -> its tile's hash (and point
// count), or "no tile here". It is learned from ROI answers and the disk cache; a key it does not
// know is one to ask the server about. Plain data and logic, no locking. Private to pl_client.
#pragma once

#include <map>
#include <unordered_map>
#include <string>
#include <vector>

#include "pl/client/tile_cache.hpp"
#include "pl/common/tile_key.hpp"

namespace pl::client {

class TileIndex {
 public:
  // What the version holds at `key`: nullptr when the key is not known. A complete index knows
  // every key: one it holds no row for has no tile (a "no tile here" row).
  const CachedTile* find(const TileKey& key) const;
  bool knows(const TileKey& key) const { return complete_ || rows_.count(key) > 0; }
  // The rows are the whole version (from its signed manifest): no key is left to ask about.
  void set_complete() { complete_ = true; }
  bool complete() const { return complete_; }
  std::size_t size() const { return rows_.size(); }

  // Records what the version holds at a key (replacing what was known there).
  void learn(CachedTile row);
  // Forgets a key (its row proved stale): the next ROI answer learns it afresh.
  void forget(const TileKey& key) { rows_.erase(key); }
  // Forgets everything: another version is pinned.
  void clear();

  // Whether ROI queries may name the tiles already known by hash (have=): false once one hash was
  // seen at two keys, as the server would then leave out both keys for the one hash.
  bool have_usable() const { return have_usable_; }

 private:
  std::unordered_map<TileKey, CachedTile, TileKeyHash> rows_;  // looked up for every key of every plan
  std::map<std::string, TileKey> key_of_hash_;  // the first key each hash was seen at
  bool have_usable_ = true;
  bool complete_ = false;
};

// An ROI answer for the keys in `keys` (those of the disc asked about): the tiles it lists, plus a
// "no tile here" row for each of `keys` that the answer leaves out and the index does not know
// (have= leaves out only tiles the index knows).
std::vector<CachedTile> rows_of_answer(std::vector<CachedTile> listed, const std::vector<TileKey>& keys, const TileIndex& index);

}  // namespace pl::client
