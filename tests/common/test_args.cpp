// DEPRECATED parser (pl/common/args.hpp), kept while pl-localize uses it.
#include <gtest/gtest.h>

#include "pl/common/cli.hpp"
#include "pl/common/error.hpp"

namespace {
pl::Args parse(std::vector<std::string> words, std::set<std::string> switches = {}) {
  static std::vector<std::string> keep;
  keep = std::move(words);
  static std::vector<char*> argv;
  argv.clear();
  for (auto& w : keep) argv.push_back(w.data());
  return pl::Args(static_cast<int>(argv.size()), argv.data(), 1, std::move(switches));
}
}  // namespace

TEST(Args, FlagsSwitchesAndPositionals) {
  pl::Args a = parse({"prog", "info", "DIR", "--out", "x.txt", "--voxel=0.25", "--json"}, {"--json"});
  EXPECT_EQ(a.positional(), (std::vector<std::string>{"info", "DIR"}));
  EXPECT_EQ(a.require("--out", "FILE"), "x.txt");
  EXPECT_DOUBLE_EQ(a.get_double("--voxel", 0.2), 0.25);
  EXPECT_TRUE(a.has("--json"));
  EXPECT_EQ(a.get_int("--frames", 7), 7);
  EXPECT_NO_THROW(a.finish());
}

TEST(Args, RepeatedFlagsKeepEveryValueInOrder) {
  pl::Args a = parse({"prog", "--traj", "a.txt", "--cell", "2", "--traj=b.txt:B", "--traj", "c.tum"});
  EXPECT_EQ(a.get_all("--traj"), (std::vector<std::string>{"a.txt", "b.txt:B", "c.tum"}));
  EXPECT_EQ(a.get("--traj"), "c.tum");  // a single get keeps the last one
  EXPECT_TRUE(a.get_all("--none").empty());
  EXPECT_DOUBLE_EQ(a.get_double("--cell", 1.0), 2.0);
  EXPECT_NO_THROW(a.finish());
  pl::Args s = parse({"prog", "--traj", "--json"}, {"--traj", "--json"});
  EXPECT_THROW(s.get_all("--traj"), pl::Error);  // given as a switch, without a value
}

TEST(Args, ErrorsNameTheFlag) {
  pl::Args a = parse({"prog", "--voxel", "abc", "--typo", "1"});
  try {
    a.get_double("--voxel", 0.2);
    FAIL();
  } catch (const pl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("--voxel takes a number"), std::string::npos);
  }
  try {
    a.finish();
    FAIL();
  } catch (const pl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("--typo"), std::string::npos);
  }
  EXPECT_THROW(a.require("--out", "FILE"), pl::Error);
  EXPECT_THROW(parse({"prog", "--out"}), pl::Error);
}
