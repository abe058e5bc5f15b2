#include "pl/eval/timing.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "eval_test_util.hpp"
#include "pl/common/error.hpp"

namespace pl::eval {
namespace {

using test::TempDir;
using test::write_text;

std::string error_of(const std::string& path, const std::optional<std::string>& column) {
  try {
    read_timing_csv(path, column);
  } catch (const pl::Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(EvalTiming, DefaultColumnIsRegistrationMs) {
  TempDir dir;
  const std::string csv = dir.file("t.csv");
  write_text(csv, "scan,load_ms,registration_ms,points\n0,1.5,12.25,1000\n1,1.0,14.5,1100\n\n# a comment\n2,2,9,900\n");
  const TimingColumn c = read_timing_csv(csv, std::nullopt);
  EXPECT_EQ(c.name, "registration_ms");
  EXPECT_EQ(c.values, (std::vector<double>{12.25, 14.5, 9.0}));
  EXPECT_EQ(c.all_columns.size(), 4u);
}

TEST(EvalTiming, OnlyMsColumnIsTheDefault) {
  TempDir dir;
  const std::string csv = dir.file("t.csv");
  write_text(csv, "scan, total_ms ,points\r\n0, 3.5 ,10\r\n1,4.5,20\r\n");
  const TimingColumn c = read_timing_csv(csv, std::nullopt);
  EXPECT_EQ(c.name, "total_ms");
  EXPECT_EQ(c.values, (std::vector<double>{3.5, 4.5}));
}

TEST(EvalTiming, AmbiguousColumnsAreAnErrorListingThem) {
  TempDir dir;
  const std::string csv = dir.file("t.csv");
  write_text(csv, "scan,load_ms,match_ms\n0,1,2\n");
  const std::string msg = error_of(csv, std::nullopt);
  EXPECT_NE(msg.find(csv), std::string::npos) << msg;
  EXPECT_NE(msg.find("scan, load_ms, match_ms"), std::string::npos) << msg;
  EXPECT_NE(msg.find("--column"), std::string::npos) << msg;

  const TimingColumn c = read_timing_csv(csv, std::string("match_ms"));
  EXPECT_EQ(c.values, (std::vector<double>{2.0}));
  const std::string missing = error_of(csv, std::string("nope"));
  EXPECT_NE(missing.find("no column named \"nope\""), std::string::npos) << missing;
  EXPECT_NE(missing.find("load_ms"), std::string::npos) << missing;
}

TEST(EvalTiming, NoMsColumnIsAnError) {
  TempDir dir;
  const std::string csv = dir.file("t.csv");
  write_text(csv, "scan,points\n0,1\n");
  EXPECT_NE(error_of(csv, std::nullopt).find("ends in _ms"), std::string::npos);
}

TEST(EvalTiming, BadRowsNameTheFileAndLine) {
  TempDir dir;
  const std::string csv = dir.file("t.csv");
  write_text(csv, "scan,registration_ms\n0,1.0\n1,abc\n");
  std::string msg = error_of(csv, std::nullopt);
  EXPECT_NE(msg.find(csv + ":3"), std::string::npos) << msg;
  EXPECT_NE(msg.find("registration_ms"), std::string::npos) << msg;

  write_text(csv, "scan,registration_ms\n0,1.0\n1,2.0\n2\n");
  msg = error_of(csv, std::nullopt);
  EXPECT_NE(msg.find(csv + ":4"), std::string::npos) << msg;
  EXPECT_NE(msg.find("2 comma-separated fields"), std::string::npos) << msg;

  write_text(csv, "scan,registration_ms\n0,\n");  // an empty field stays a field, and is not a number
  msg = error_of(csv, std::nullopt);
  EXPECT_NE(msg.find(csv + ":2"), std::string::npos) << msg;

  write_text(csv, "scan,registration_ms\n");
  EXPECT_NE(error_of(csv, std::nullopt).find("no data rows"), std::string::npos);
  write_text(csv, "");
  EXPECT_NE(error_of(csv, std::nullopt).find("empty file"), std::string::npos);
  EXPECT_NE(error_of(dir.file("missing.csv"), std::nullopt).find("cannot open"), std::string::npos);
}

TEST(EvalTiming, StatsOnOneToHundred) {
  std::vector<double> v;
  for (int i = 1; i <= 100; ++i) v.push_back(i);
  std::shuffle(v.begin(), v.end(), std::mt19937(1));
  const TimingStats s = timing_stats(v);
  EXPECT_EQ(s.count, 100u);
  EXPECT_DOUBLE_EQ(s.mean, 50.5);
  // Interpolated between the closest ranks (pl/common/stats.hpp): h = 99p/100 on 1..100.
  EXPECT_DOUBLE_EQ(s.p50, 50.5);   // h = 49.5: between 50 and 51
  EXPECT_DOUBLE_EQ(s.p90, 90.1);   // h = 89.1
  EXPECT_DOUBLE_EQ(s.p99, 99.01);  // h = 98.01
  EXPECT_DOUBLE_EQ(s.max, 100.0);
  EXPECT_DOUBLE_EQ(s.min, 1.0);
}

TEST(EvalTiming, StatsOnAShortList) {
  // 10 20 ... 70: h = 6p/100. p50 -> h = 3, the 4th value; p90 -> h = 5.4, 60 + 0.4 * 10;
  // p99 -> h = 5.94, 60 + 0.94 * 10.
  const TimingStats s = timing_stats({30, 10, 70, 20, 60, 40, 50});
  EXPECT_DOUBLE_EQ(s.p50, 40.0);
  EXPECT_DOUBLE_EQ(s.p90, 64.0);
  EXPECT_DOUBLE_EQ(s.p99, 69.4);
  EXPECT_DOUBLE_EQ(s.mean, 40.0);
}

TEST(EvalTiming, TextHistogramHasOneLinePerBinAndScaledBars) {
  const Histogram h = make_histogram({1, 1, 1, 1, 2, 3, 3, 4}, 4);
  const std::string text = text_histogram(h, 20, 1);
  EXPECT_EQ(test::count_of(text, "\n"), 4u);
  EXPECT_NE(text.find("[1.0, 1.8)       4 ####################\n"), std::string::npos) << text;
  EXPECT_NE(text.find("[3.2, 4.0]       1 #####\n"), std::string::npos) << text;
}

}  // namespace
}  // namespace pl::eval
