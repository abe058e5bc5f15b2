// Cloud files as bytes for the cloud reader tests (test_cloud_io*.cpp): what reading or parsing one
// says, raw values, PCD headers, and what PCL wrote for one small organised cloud.
#pragma once

#include <gtest/gtest.h>

#include <initializer_list>
#include <string>
#include <vector>

#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "test_util.hpp"

// Its own namespace: error_of.hpp has a pl::test::error_of of a callable, and other tests' helpers a
// contains() of their own.
namespace pl::test::cloud_files {

// The message of reading the cloud file `path`, or "(no error)".
inline std::string error_of(const std::string& path) {
  try {
    pl::read_cloud(path);
  } catch (const pl::Error& e) {
    return e.what();
  }
  return "(no error)";
}

// Whether an error message says what it should; on failure the test shows both.
inline testing::AssertionResult contains(const std::string& message, const std::string& part) {
  if (message.find(part) != std::string::npos) return testing::AssertionSuccess();
  return testing::AssertionFailure() << "the message \"" << message << "\"\ndoes not contain \"" << part << "\"";
}

// The message of parsing these bytes as the file `name` (by its extension), or "(no error)".
inline std::string parse_error(const std::string& bytes, const std::string& name) {
  try {
    pl::parse_cloud(bytes, name);
  } catch (const pl::Error& e) {
    return e.what();
  }
  return "(no error)";
}

template <typename T>
std::string raw(std::initializer_list<T> values) {
  std::string out;
  for (T v : values) out.append(reinterpret_cast<const char*>(&v), sizeof(T));
  return out;
}

// A PCD header with one line per key (COUNT left out when empty) and DATA last.
inline std::string pcd_header(const std::string& fields, const std::string& sizes, const std::string& types,
                              const std::string& counts, const std::string& rest) {
  return "FIELDS " + fields + "\nSIZE " + sizes + "\nTYPE " + types + "\n" + (counts.empty() ? "" : "COUNT " + counts + "\n") + rest;
}

// What PCL 1.13 (Debian's libpcl-io, pcl::io::savePCDFileBinaryCompressed, savePCDFileBinary,
// savePCDFileASCII) wrote for an organised 3 x 2 pcl::PointXYZI cloud whose second and fifth points
// are NaN (no return), the others (1.5, -2.25, 0.125) 10, (100.75, 200.5, -3) 255.5, (-0.5, 0.25, 7) 3
// and (12, -13.5, 14.25) 65535.
inline const std::string kPclXyziHeader =
    "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\n"
    "COUNT 1 1 1 1\nWIDTH 3\nHEIGHT 2\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 6\n";
inline const std::string kPclXyziCompressed =
    kPclXyziHeader + "DATA binary_compressed\n" +
    from_hex(
        "51000000600000000f0000c03f0000c07f0080c942000000bf600b06004041000010c0600b068048430000803e600b02"
        "0058c12023a00b0040201f01e04080170064202f00202003200001807f202f00402017200002ff7f47");
inline const std::string kPclXyziBinary =
    kPclXyziHeader + "DATA binary\n" +
    from_hex(
        "0000c03f000010c00000003e000020410000c07f0000c07f0000c07f000000000080c94200804843000040c000807f43"
        "000000bf0000803e0000e040000040400000c07f0000c07f0000c07f0000000000004041000058c10000644100ff7f47");
inline const std::string kPclXyziAscii = kPclXyziHeader +
                                         "DATA ascii\n1.5 -2.25 0.125 10\nnan nan nan 0\n100.75 200.5 -3 255.5\n-0.5 0.25 7 3\n"
                                         "nan nan nan 0\n12 -13.5 14.25 65535\n";
inline const pl::Points3d kPclXyziPoints = {Eigen::Vector3d(1.5, -2.25, 0.125), Eigen::Vector3d(100.75, 200.5, -3),
                                            Eigen::Vector3d(-0.5, 0.25, 7), Eigen::Vector3d(12, -13.5, 14.25)};
inline const std::vector<float> kPclXyziIntensity = {10, 255.5, 3, 65535};

}  // namespace pl::test::cloud_files
