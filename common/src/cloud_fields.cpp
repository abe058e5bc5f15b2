#include "cloud_fields.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "pl/common/error.hpp"

namespace pl::cloud_detail {

// The scalars this reader decodes: float32/64 and 8- to 64-bit integers. Anything else is refused
// when the header is read, so that no field decodes to a silent NaN.
bool supported_scalar(char type, std::size_t size) {
  if (type == 'F') return size == 4 || size == 8;
  if (type == 'I' || type == 'U') return size == 1 || size == 2 || size == 4 || size == 8;
  return false;
}

double read_scalar(const char* p, const Field& f) {
  switch (f.type) {
    case 'F':
      if (f.size == 4) { float v; std::memcpy(&v, p, 4); return v; }
      if (f.size == 8) { double v; std::memcpy(&v, p, 8); return v; }
      break;
    case 'I':
      if (f.size == 1) { std::int8_t v; std::memcpy(&v, p, 1); return v; }
      if (f.size == 2) { std::int16_t v; std::memcpy(&v, p, 2); return v; }
      if (f.size == 4) { std::int32_t v; std::memcpy(&v, p, 4); return v; }
      if (f.size == 8) { std::int64_t v; std::memcpy(&v, p, 8); return static_cast<double>(v); }
      break;
    case 'U':
      if (f.size == 1) { std::uint8_t v; std::memcpy(&v, p, 1); return v; }
      if (f.size == 2) { std::uint16_t v; std::memcpy(&v, p, 2); return v; }
      if (f.size == 4) { std::uint32_t v; std::memcpy(&v, p, 4); return v; }
      if (f.size == 8) { std::uint64_t v; std::memcpy(&v, p, 8); return static_cast<double>(v); }
      break;
  }
  return NAN;  // not reached: supported_scalar() vetted every field
}

bool is_intensity_name(const std::string& n) {
  return n == "intensity" || n == "reflectance" || n == "scalar_intensity" || n == "i" || n == "remission";
}

RecordShape lay_out(std::vector<Field>& fields, const std::string& name) {
  RecordShape shape;
  for (auto& f : fields) {
    f.offset = shape.stride;
    f.column = shape.columns;
    std::size_t bytes = 0;
    if (!checked_mul(f.size, f.count, bytes) || !checked_add(shape.stride, bytes, shape.stride) ||
        !checked_add(shape.columns, f.count, shape.columns))
      throw Error(name + ": field " + in_quotes(f.name) + " has COUNT " + std::to_string(f.count) +
                  ": the record size overflows (a damaged header?)");
  }
  return shape;
}

Roles find_roles(const std::vector<Field>& fields, const std::string& name) {
  std::optional<std::size_t> x, y, z;
  Roles r;
  for (std::size_t k = 0; k < fields.size(); ++k) {
    if (fields[k].name == "x") x = k;
    if (fields[k].name == "y") y = k;
    if (fields[k].name == "z") z = k;
    if (!r.intensity && is_intensity_name(fields[k].name)) r.intensity = k;
  }
  if (!x || !y || !z) throw Error(name + ": needs x, y and z fields");
  r.x = *x, r.y = *y, r.z = *z;
  return r;
}

// float32 holds the intensity: a value beyond its range would become inf, so it is refused.
float to_intensity(double v, std::size_t i, const std::string& name) {
  if (!(std::abs(v) <= FLT_MAX))
    throw Error(name + ": point " + std::to_string(i + 1) + " has an intensity that is not a finite float32 value");
  return static_cast<float>(v);
}


// The points decoded so far. A dropped point takes its intensity with it, so the intensities stay
// one per point kept.
class PointSink {
 public:
  PointSink(Cloud& cloud, std::size_t n, bool intensity, NonFinite policy, const std::string& name)
      : cloud_(cloud), policy_(policy), name_(name) {
    cloud_.points.resize(n);
    if (intensity) cloud_.intensity.resize(n);
  }
  // False when the point is dropped: its intensity is then not wanted. `i` counts the points of the
  // file from 0, dropped or not, for messages.
  bool add(const Eigen::Vector3d& p, std::size_t i) {
    if (!p.allFinite()) {
      if (policy_ == NonFinite::Refuse)
        throw Error(name_ + ": point " + std::to_string(i + 1) +
                    " has a non-finite coordinate (NaN or inf; drop invalid points first)");
      ++dropped_;
      return false;
    }
    cloud_.points[kept_] = p;
    return true;
  }
  // The intensity of the point add() just kept.
  void intensity(double v, std::size_t i) { cloud_.intensity[kept_] = to_intensity(v, i, name_); }
  void next() { ++kept_; }
  // Gives the cloud its size; the memory of the points dropped is handed back when they were many
  // (an organised cloud of a sensor that saw little).
  void finish() {
    cloud_.points.resize(kept_);
    if (!cloud_.intensity.empty()) cloud_.intensity.resize(kept_);
    if (dropped_ > kept_) {
      cloud_.points.shrink_to_fit();
      cloud_.intensity.shrink_to_fit();
    }
  }

 private:
  Cloud& cloud_;
  NonFinite policy_;
  const std::string& name_;
  std::size_t kept_ = 0, dropped_ = 0;
};

BinaryLayout record_layout(const std::vector<Field>& fields, const RecordShape& shape) {
  BinaryLayout l;
  for (const auto& f : fields) {
    l.base.push_back(f.offset);
    l.step.push_back(shape.stride);
  }
  return l;
}

// The caller has checked that `data` holds every value of the n points where `layout` puts it.
void decode_binary(Cloud& cloud, const std::vector<Field>& fields, const Roles& r, const BinaryLayout& layout, std::size_t n,
                   std::string_view data, NonFinite policy, const std::string& name) {
  PointSink sink(cloud, n, r.intensity.has_value(), policy, name);
  for (std::size_t i = 0; i < n; ++i) {
    auto value = [&](std::size_t k) { return read_scalar(data.data() + layout.base[k] + i * layout.step[k], fields[k]); };
    if (!sink.add(Eigen::Vector3d(value(r.x), value(r.y), value(r.z)), i)) continue;
    if (r.intensity) sink.intensity(value(*r.intensity), i);
    sink.next();
  }
  sink.finish();
}

// `what` names the declared count for messages ("POINTS", "element vertex").
void fill_binary(Cloud& cloud, const std::vector<Field>& fields, const Roles& r, const RecordShape& shape, std::size_t n,
                 std::string_view data, NonFinite policy, const std::string& name, const std::string& what) {
  std::size_t need = 0;
  const bool fits = checked_mul(n, shape.stride, need);
  if (!fits || need > data.size())
    throw Error(name + ": " + what + " " + std::to_string(n) + " needs " +
                (fits ? std::to_string(need) : std::string("more than 2^64")) + " bytes of binary data (" +
                std::to_string(shape.stride) + " a point), the file has " + std::to_string(data.size()) +
                " after the header (truncated?)");
  decode_binary(cloud, fields, r, record_layout(fields, shape), n, data, policy, name);
}

// An ascii value of a PCD: a number or, for a point without a return, a non-finite value as PCL
// ("nan") and printf ("-nan", "inf") write it. An out-of-range number ("1e400") stays an error.
bool parse_pcd_value(std::string_view text, double& out) {
  if (parse_double(text, out)) return true;
  std::string word;
  for (char c : text) word += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const bool negative = !word.empty() && word[0] == '-';
  if (!word.empty() && (word[0] == '-' || word[0] == '+')) word.erase(0, 1);
  if (word == "nan") {
    out = NAN;
    return true;
  }
  if (word == "inf" || word == "infinity") {
    out = negative ? -INFINITY : INFINITY;
    return true;
  }
  return false;
}

void fill_ascii(Cloud& cloud, const std::vector<Field>& fields, const Roles& r, const RecordShape& shape, std::size_t n,
                std::string_view data, NonFinite policy, const std::string& name, const std::string& what) {
  // A point is a line of `columns` values of at least one character, each followed by a separator
  // (the last line may lack its newline): fewer bytes cannot hold the points declared, so the
  // declared count is refused before it sizes anything.
  std::size_t per_point = 0, need = 0;
  const bool fits = checked_mul(shape.columns, 2, per_point) && checked_mul(n, per_point, need);
  if (n > 0 && (!fits || need - 1 > data.size()))
    throw Error(name + ": " + what + " " + std::to_string(n) + " needs at least " +
                (fits ? std::to_string(need - 1) : std::string("2^64")) + " bytes of ascii data (a line of " +
                std::to_string(shape.columns) + " values a point), the file has " + std::to_string(data.size()) +
                " after the header (truncated?)");
  // Only where a non-finite point is dropped may a value spell one; elsewhere "nan" is not a number.
  auto parse = [&](std::string_view text, double& out) {
    return policy == NonFinite::Drop ? parse_pcd_value(text, out) : parse_double(text, out);
  };
  PointSink sink(cloud, n, r.intensity.has_value(), policy, name);
  std::size_t pos = 0;
  for (std::size_t i = 0; i < n;) {
    if (pos >= data.size()) throw Error(name + ": truncated: expected " + std::to_string(n) + " points, found " + std::to_string(i));
    std::size_t end = data.find('\n', pos);
    if (end == std::string_view::npos) end = data.size();
    const auto v = split_fields(data.substr(pos, end - pos), " \t\r");
    pos = end + 1;
    if (v.empty()) continue;  // blank lines carry no point
    if (v.size() < shape.columns)
      throw Error(name + ": point " + std::to_string(i + 1) + " has " + std::to_string(v.size()) + " values, expected " +
                  std::to_string(shape.columns));
    double x, y, z;
    if (!parse(v[fields[r.x].column], x) || !parse(v[fields[r.y].column], y) || !parse(v[fields[r.z].column], z))
      throw Error(name + ": point " + std::to_string(i + 1) + " has a coordinate that is not a number");
    double val = 0;
    if (!sink.add(Eigen::Vector3d(x, y, z), i)) {
      // A point without a return goes, but a line that is not numbers is damage all the same.
      if (r.intensity && !parse(v[fields[*r.intensity].column], val))
        throw Error(name + ": point " + std::to_string(i + 1) + " has an intensity that is not a number");
      ++i;
      continue;
    }
    if (r.intensity) {
      if (!parse_double(v[fields[*r.intensity].column], val))
        throw Error(name + ": point " + std::to_string(i + 1) + " has an intensity that is not a number");
      sink.intensity(val, i);
    }
    sink.next();
    ++i;
  }
  sink.finish();
}

void fill(Cloud& cloud, std::vector<Field>& fields, std::size_t n, std::string_view data, bool binary, NonFinite policy,
          const std::string& name, const std::string& what) {
  const Roles roles = find_roles(fields, name);
  const RecordShape shape = lay_out(fields, name);
  if (binary)
    fill_binary(cloud, fields, roles, shape, n, data, policy, name, what);
  else
    fill_ascii(cloud, fields, roles, shape, n, data, policy, name, what);
}

}  // namespace pl::cloud_detail
