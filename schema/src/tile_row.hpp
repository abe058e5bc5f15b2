// A tiles row read the same way on both engines: R is SQLite's Row or PostgreSQL's PgRow (the same
// integer / number / hash / bad), the columns tx, ty, hash, points, bytes, min_x .. max_z from
// `first` on. A key outside int32, a negative count or a box with min > max is damage.
#pragma once

#include <cstdint>
#include <limits>

#include "pl/schema/store.hpp"

namespace pl::store::detail {

template <typename R>
TileRecord tile_row(const R& row, int first) {
  constexpr std::int64_t lo = std::numeric_limits<std::int32_t>::min(), hi = std::numeric_limits<std::int32_t>::max();
  TileRecord t;
  t.key = TileKey{static_cast<std::int32_t>(row.integer(first, "tx", lo, hi)), static_cast<std::int32_t>(row.integer(first + 1, "ty", lo, hi))};
  t.hash = row.hash(first + 2, "hash");
  t.points = row.integer(first + 3, "points", 0);
  t.bytes = row.integer(first + 4, "bytes", 0);
  t.min_x = row.number(first + 5, "min_x");
  t.min_y = row.number(first + 6, "min_y");
  t.min_z = row.number(first + 7, "min_z");
  t.max_x = row.number(first + 8, "max_x");
  t.max_y = row.number(first + 9, "max_y");
  t.max_z = row.number(first + 10, "max_z");
  if (!(t.min_x <= t.max_x && t.min_y <= t.max_y && t.min_z <= t.max_z)) row.bad("min_x", "and the other bounds have min > max");
  return t;
}

}  // namespace pl::store::detail
