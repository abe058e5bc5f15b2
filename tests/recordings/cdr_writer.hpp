// A CDR writer for the tests' own ROS 2 messages.
#pragma once

#include <cstdint>
#include <string>

namespace pl::test {

// CDR as ROS 2 writes it: the little-endian encapsulation header, then each primitive aligned to its
// size from the end of the header, strings with their NUL counted.
class CdrWriter {
 public:
  CdrWriter() { b_ = std::string("\x00\x01\x00\x00", 4); }
  template <typename T>
  CdrWriter& put(T v) {
    while ((b_.size() - 4) % sizeof(T)) b_.push_back('\0');
    b_.append(reinterpret_cast<const char*>(&v), sizeof(T));
    return *this;
  }
  CdrWriter& str(const std::string& s) {
    put<std::uint32_t>(static_cast<std::uint32_t>(s.size() + 1));
    b_ += s;
    b_.push_back('\0');
    return *this;
  }
  CdrWriter& raw(const std::string& s) {
    b_ += s;
    return *this;
  }
  CdrWriter& header(std::int32_t sec, std::uint32_t nsec, const std::string& frame) { return put(sec).put(nsec).str(frame); }
  const std::string& bytes() const { return b_; }

 private:
  std::string b_;
};

}  // namespace pl::test
