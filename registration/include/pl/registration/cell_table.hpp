// The one voxel hash of the project: integer cell coordinates packed into a 63-bit key, and an
// open-addressing table (linear probing, deletion by backward shift) from keys to a small value.
// The localizer's point map and LOAM's feature maps are both uses of it. It stores no points: the
// value says where the caller keeps a cell's content.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <vector>

namespace pl::registration {

// Cell coordinates, 21 bits each in two's complement (+-2^20 cells round the frame's origin).
inline std::uint64_t pack_cell(std::int64_t x, std::int64_t y, std::int64_t z) {
  constexpr std::uint64_t m = (std::uint64_t{1} << 21) - 1;
  return (static_cast<std::uint64_t>(x) & m) | ((static_cast<std::uint64_t>(y) & m) << 21) |
         ((static_cast<std::uint64_t>(z) & m) << 42);
}

// Whether pack_cell keeps the cell apart from every other: each coordinate within +-2^20.
constexpr std::int64_t kCellReach = std::int64_t{1} << 20;
inline bool packs(std::int64_t x, std::int64_t y, std::int64_t z) {
  return std::abs(x) < kCellReach && std::abs(y) < kCellReach && std::abs(z) < kCellReach;
}

inline std::int64_t cell_coordinate(float v, float inv_cell) { return static_cast<std::int64_t>(std::floor(v * inv_cell)); }

// Key -> Value. Value must be default-constructible and cheap to copy (an index, a pointer and a count).
template <typename Value>
class CellTable {
 public:
  CellTable() { rehash(1024); }

  // The value under key, or nullptr.
  const Value* find(std::uint64_t key) const {
    for (std::size_t i = home(key);; i = (i + 1) & mask_) {
      const Entry& e = entries_[i];
      if (e.key == key) return &e.value;
      if (e.key == kEmpty) return nullptr;
    }
  }
  // Asks the processor to bring key's home slot into the cache (a lookup soon after finds it there).
  void prefetch(std::uint64_t key) const { __builtin_prefetch(&entries_[home(key)]); }
  // Stores `value` under key unless the key is there; returns the stored value and whether it is new.
  // The pointer is valid until the next insert or erase.
  Value* insert(std::uint64_t key, const Value& value, bool& fresh) {
    if (2 * (used_ + 1) > entries_.size()) rehash(entries_.size() * 2);
    std::size_t i = home(key);
    for (; entries_[i].key != kEmpty; i = (i + 1) & mask_)
      if (entries_[i].key == key) {
        fresh = false;
        return &entries_[i].value;
      }
    entries_[i].key = key;
    entries_[i].value = value;
    ++used_;
    fresh = true;
    return &entries_[i].value;
  }
  bool erase(std::uint64_t key) {
    std::size_t i = home(key);
    while (entries_[i].key != key) {
      if (entries_[i].key == kEmpty) return false;
      i = (i + 1) & mask_;
    }
    // Backward shift: later members of the probe run move into the hole when their home allows it.
    for (std::size_t j = (i + 1) & mask_;; j = (j + 1) & mask_) {
      if (entries_[j].key == kEmpty) break;
      const std::size_t h = home(entries_[j].key);
      const bool movable = i <= j ? (h <= i || h > j) : (h <= i && h > j);
      if (movable) {
        entries_[i] = entries_[j];
        i = j;
      }
    }
    entries_[i] = Entry{};
    --used_;
    return true;
  }
  template <typename F>
  void for_each(F&& f) const {
    for (const Entry& e : entries_)
      if (e.key != kEmpty) f(e.key, e.value);
  }
  std::size_t size() const { return used_; }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};  // packed keys use 63 bits
  struct Entry {
    std::uint64_t key = kEmpty;
    Value value{};
  };
  std::vector<Entry> entries_;
  std::size_t mask_ = 0, used_ = 0;

  // A strong mix of all 63 bits: neighbouring cells differ in a few low bits of each field.
  std::size_t home(std::uint64_t k) const {
    k ^= k >> 31;
    k *= 0x7fb5d329728ea185ull;
    k ^= k >> 27;
    k *= 0x81dadef4bc2dd44dull;
    k ^= k >> 33;
    return static_cast<std::size_t>(k) & mask_;
  }
  void rehash(std::size_t capacity) {
    std::vector<Entry> old = std::move(entries_);
    entries_.assign(capacity, Entry{});
    mask_ = capacity - 1;
    used_ = 0;
    bool fresh;
    for (const Entry& e : old)
      if (e.key != kEmpty) insert(e.key, e.value, fresh);
  }
};

}  // namespace pl::registration
