// Recordings robots make, read without ROS: ROS 1 bags (.bag, chunks plain, bz2 or lz4), ROS 2 bags
// (a folder with metadata.yaml and .db3 SQLite files, or one .db3) and MCAP files (ROS 1 or CDR
// messages, chunks plain, zstd or lz4). A reader lists the topics and every message in time order
// and hands out a message's serialized bytes on demand; pl/recordings/ros_msgs.hpp decodes them.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace pl::bag {

// How a topic's messages are serialized: ROS 1's (little-endian, packed) or CDR (ROS 2; the bytes
// begin with the 4-byte encapsulation header).
enum class Encoding { Ros1, Cdr };

struct Topic {
  std::string name;        // "/velodyne_points"
  std::string type;        // "sensor_msgs/PointCloud2" (ROS 2's "sensor_msgs/msg/PointCloud2" is given so too)
  Encoding encoding = Encoding::Ros1;
  std::string definition;  // the message definition when the file carries one, else empty
  std::size_t count = 0;   // its messages in the file
};

// One message: the topic (an index into topics()), the time it was recorded (nanoseconds since
// 1970, the recorder's clock; a message's own header stamp may differ), and where it lies (the
// reader's business).
struct MessageRef {
  std::uint32_t topic = 0;
  std::int64_t time_ns = 0;
  std::uint64_t where = 0;
  std::uint64_t offset = 0;
  std::uint64_t size = 0;  // bytes as stored (in a ROS 2 bag compressed per message, the compressed size: read() may give more)
};

// Bytes a reader reads from: a file mapped into memory, or bytes held (a test's, a fuzzer's).
class Source {
 public:
  virtual ~Source() = default;
  virtual std::string_view bytes() const = 0;
  const std::string& name() const { return name_; }  // the file, for messages

 protected:
  explicit Source(std::string name) : name_(std::move(name)) {}

 private:
  std::string name_;
};
std::shared_ptr<const Source> map_file(const std::string& path);  // throws pl::Error when unreadable
std::shared_ptr<const Source> hold_bytes(std::string bytes, const std::string& name);

class Reader {
 public:
  virtual ~Reader() = default;
  virtual const char* format() const = 0;  // "ROS 1 bag", "ROS 2 bag", "MCAP"
  const std::string& path() const { return path_; }
  const std::vector<Topic>& topics() const { return topics_; }
  // Every message of every topic, by time (ties in file order).
  const std::vector<MessageRef>& messages() const { return messages_; }
  // The serialized message. The view stays valid until the next read() on this reader (a chunk's
  // decompressed bytes are kept for the next message in it). Not safe from several threads at once.
  // Throws pl::Error naming the file, the offset (or a ROS 2 bag's table and row) and the problem.
  virtual std::string_view read(const MessageRef& m) = 0;

 protected:
  std::string path_;
  std::vector<Topic> topics_;
  std::vector<MessageRef> messages_;
};

// The reader a file's first bytes (or a folder's metadata.yaml / .db3 files) call for. Throws
// pl::Error naming the file when it is none of the three, and what it found instead.
std::unique_ptr<Reader> open(const std::string& path);
// True when `path` is a bag or MCAP file, or a ROS 2 bag folder (a cheap look at its first bytes).
bool is_recording(const std::string& path);

// The readers on a source (the file readers above map the file and call these). Every length and
// offset in the bytes is checked before it is used: damaged or hostile input is refused with a
// pl::Error ("FILE: offset N: PROBLEM"), never read out of bounds.
std::unique_ptr<Reader> open_ros1(std::shared_ptr<const Source> src);
std::unique_ptr<Reader> open_mcap(std::shared_ptr<const Source> src);
// A ROS 2 bag: a folder (metadata.yaml and its .db3 files) or one .db3 file.
std::unique_ptr<Reader> open_ros2(const std::string& path);

}  // namespace pl::bag
