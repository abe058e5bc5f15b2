// A cursor over one serialized ROS message in either encoding: ROS 1 packs fields with no padding and
// prefixes strings and sequences with a u32 length; CDR (ROS 2) starts with a 4-byte encapsulation
// header, aligns each primitive to its own size counted from the end of that header, and counts a
// string's terminating NUL in its length. ROS 1's std_msgs/Header has a u32 seq that ROS 2 dropped.
#pragma once

#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

#include "byte_reader.hpp"
#include "pl/recordings/ros_msgs.hpp"

namespace pl::ros {

class Cursor {
 public:
  Cursor(std::string_view bytes, bag::Encoding enc, const std::string& name) : r_(bytes, name), cdr_(enc == bag::Encoding::Cdr) {
    if (cdr_) {
      const std::uint8_t h0 = r_.u8("the CDR encapsulation header"), h1 = r_.u8("the CDR encapsulation header");
      r_.u16("the CDR encapsulation options");
      if (h0 != 0 || (h1 != 1 && h1 != 0))
        r_.fail_at_offset(0, "unknown CDR encapsulation " + std::to_string(h0) + "," + std::to_string(h1) +
                                 " (expected 0,1: plain little-endian CDR as ROS 2 writes it)");
      if (h1 == 0) r_.fail_at_offset(0, "big-endian CDR is not supported (record on a little-endian machine, or convert the bag)");
    }
  }

  template <typename T>
  T get(const char* what) {
    align(sizeof(T));
    return r_.get<T>(what);
  }
  double f64(const char* what) { return get<double>(what); }
  std::uint32_t u32(const char* what) { return get<std::uint32_t>(what); }

  std::string str(const char* what) {
    const std::uint32_t n = u32(what);
    std::string_view s = r_.bytes(n, what);
    if (cdr_) {
      if (n == 0 || s.back() != '\0') fail(std::string(what) + ": a CDR string must end in a NUL counted in its length");
      s.remove_suffix(1);
    }
    return std::string(s);
  }
  // A sequence's length, checked against the bytes left at `least` bytes an element.
  std::uint32_t count(const char* what, std::size_t least) {
    const std::uint32_t n = u32(what);
    if (least > 0 && n > r_.left() / least)
      fail(std::string(what) + ": " + std::to_string(n) + " elements cannot fit in the " + std::to_string(r_.left()) + " bytes left");
    return n;
  }
  std::string_view bytes(std::uint64_t n, const char* what) { return r_.bytes(n, what); }

  Header header() {
    Header h;
    if (!cdr_) u32("the header's seq");
    const std::int64_t sec = cdr_ ? get<std::int32_t>("the header's stamp") : static_cast<std::int64_t>(u32("the header's stamp"));
    const std::uint32_t nsec = u32("the header's stamp");
    if (nsec >= 1000000000u) fail("the header's stamp has " + std::to_string(nsec) + " nanoseconds (expected below 1e9)");
    h.stamp_ns = sec * 1000000000LL + nsec;
    h.frame_id = str("the header's frame_id");
    return h;
  }
  Eigen::Vector3d vec3(const char* what) {
    Eigen::Vector3d v;
    for (int i = 0; i < 3; ++i) v[i] = f64(what);
    if (!v.allFinite()) fail(std::string(what) + " is not finite");
    return v;
  }
  Eigen::Quaterniond quat(const char* what) {
    double x = f64(what), y = f64(what), z = f64(what), w = f64(what);
    Eigen::Quaterniond q(w, x, y, z);
    const double n = q.norm();
    if (!(n > 0.5 && n < 1.5)) fail(std::string(what) + " is not a unit quaternion (norm " + std::to_string(n) + ")");
    return q.normalized();
  }
  Pose pose(const char* what) {
    Pose p = Pose::Identity();
    p.translation() = vec3(what);
    p.linear() = quat(what).toRotationMatrix();
    return p;
  }
  template <std::size_t N>
  std::array<double, N> doubles(const char* what) {
    std::array<double, N> a{};
    for (auto& v : a) v = f64(what);
    return a;
  }
  [[noreturn]] void fail(const std::string& problem) const { r_.fail(problem); }
  bool cdr() const { return cdr_; }
  std::size_t left() const { return r_.left(); }

 private:
  void align(std::size_t n) {
    if (!cdr_ || n <= 1) return;
    const std::size_t at = r_.pos() - 4;  // aligned from the end of the encapsulation header
    const std::size_t pad = (n - at % n) % n;
    r_.need(pad, "padding");
    r_.seek(r_.pos() + pad);
  }
  bag::ByteReader r_;
  bool cdr_;
};

}  // namespace pl::ros
