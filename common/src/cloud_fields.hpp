// How PCD and PLY bodies decode: the fields a header declares, where each record's values are, and
// the points they fill (finite positions, one intensity per point kept). Shared by the PCD and PLY
// readers of cloud_io.cpp; private to pl_common.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pl/common/cloud_io.hpp"
#include "pl/common/text.hpp"

namespace pl::cloud_detail {

// Size arithmetic on counts from a header: false when the result does not fit (a hostile header can
// declare any count; wrapping around would make a huge body look small).
inline bool checked_mul(std::size_t a, std::size_t b, std::size_t& out) { return !__builtin_mul_overflow(a, b, &out); }
inline bool checked_add(std::size_t a, std::size_t b, std::size_t& out) { return !__builtin_add_overflow(a, b, &out); }

inline std::string in_quotes(std::string_view text) { return "\"" + printable(text, 80) + "\""; }

struct Field {
  std::string name;
  char type = 'F';  // F float, I signed, U unsigned
  std::size_t size = 4;
  std::size_t count = 1;
  std::size_t offset = 0;  // bytes into a binary record
  std::size_t column = 0;  // values into an ascii line
};

// The records' shape: each field's byte offset and ascii column, from the sizes and counts.
struct RecordShape {
  std::size_t stride = 0;   // bytes a binary record
  std::size_t columns = 0;  // values an ascii line
};

// Where x, y, z and the intensity are among the fields.
struct Roles {
  std::size_t x = 0, y = 0, z = 0;
  std::optional<std::size_t> intensity;
};

// What a point without a finite position means. In a PCD it is a point without a return: drivers
// and PCL keep one in an organised cloud (WIDTH x HEIGHT, one point per beam and step) wherever the
// beam saw nothing, as NaN. No other format this reader takes has that convention: there it is damage.
enum class NonFinite { Refuse, Drop };
// Where the values of each field are in a binary body: field k of point i starts base[k] + i *
// step[k] bytes in. Records one after another (PCD binary, PLY) have base = the field's offset in
// the record and step = the record's size; PCD binary_compressed stores field after field.
struct BinaryLayout {
  std::vector<std::size_t> base, step;
};


// The scalars this reader decodes: float32/64 and 8- to 64-bit integers. Anything else is refused
// when the header is read, so that no field decodes to a silent NaN.
bool supported_scalar(char type, std::size_t size);

// Each field's byte offset and ascii column, from the sizes and counts (`name` names the file).
RecordShape lay_out(std::vector<Field>& fields, const std::string& name);

// Where x, y, z and the intensity are among the fields.
Roles find_roles(const std::vector<Field>& fields, const std::string& name);

// n points from a binary body laid out as `layout`.
void decode_binary(Cloud& cloud, const std::vector<Field>& fields, const Roles& r, const BinaryLayout& layout, std::size_t n,
                   std::string_view data, NonFinite policy, const std::string& name);

// n points from a body of records one after another, binary or ascii; `what` names the body.
void fill(Cloud& cloud, std::vector<Field>& fields, std::size_t n, std::string_view data, bool binary, NonFinite policy,
          const std::string& name, const std::string& what);

}  // namespace pl::cloud_detail
