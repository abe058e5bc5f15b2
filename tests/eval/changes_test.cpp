// pl-eval changes: candidate tiles scored against a changes.csv and changes_seen.csv written here,
// so every figure is known.
#include <gtest/gtest.h>

#include <string>

#include "eval_test_util.hpp"
#include "pl/common/error.hpp"
#include "pl/eval/changes.hpp"

namespace pl::eval::test {
namespace {

const char* kChanges =
    "id,class,change,x0,y0,half_x0,half_y0,yaw0,x1,y1,half_x1,half_y1,yaw1,rays_seeing\n"
    "1,parked car,moved,10.0,5.0,2.2,0.9,0,24.0,5.0,2.2,0.9,0,900\n"
    "2,container,removed,10.0,30.0,3.0,1.2,0,,,,,,0\n"
    "3,tree,grown,35.0,15.0,5.0,0.3,0,35.0,15.0,6.0,0.4,0,500\n"
    "4,small building,added,,,,,,10.0,50.0,2.5,2.0,0,1200\n"
    "5,parked car,added,,,,,,20.9,70.0,1.1,0.9,0,800\n";

// Where the rays saw each change (1 m cells): the car where it stood, tile (0,0), and where it
// stands, (1,0); the container by no ray; the hedge at its east end, (2,0), and by 5 rays on its
// long side in (1,0); the building in (0,2); the added car in (1,3), and by 7 rays just across the
// edge in (0,3).
const char* kSeen =
    "id,x,y,rays\n"
    "1,10.5,5.5,300\n1,11.5,5.5,200\n1,24.5,5.5,400\n"
    "3,40.5,15.5,60\n3,33.5,15.5,5\n"
    "4,10.5,50.5,1200\n"
    "5,21.5,70.5,790\n5,19.5,70.5,7\n";

TEST(ChangeScore, CountsTilesWhereTheRaysSawAChange) {
  TempDir dir;
  write_text(dir.path() + "/changes.csv", kChanges);
  write_text(dir.path() + "/changes_seen.csv", kSeen);
  // Candidates: (0,0) right, (1,0) right, (5,5) wrong, (0,3) not scored (7 rays there); (2,0),
  // (0,2) and (1,3) missed; (0,1), the container's, seen by no ray: no change to find.
  write_text(dir.path() + "/cand.csv",
             "tx,ty,passes,agreed,added,removed,candidate,drives\n"
             "0,0,3,9,5,4,1,a b c\n1,0,3,8,8,0,1,a b c\n2,0,3,0,0,0,0,a b c\n0,1,3,0,0,0,0,a b c\n"
             "0,2,2,1,1,0,0,a b\n1,1,3,0,0,0,0,a b c\n5,5,3,12,0,12,1,a b c\n0,3,3,5,5,0,1,a b c\n1,3,3,0,0,0,0,a b c\n");
  const ChangeScore s = score_changes(dir.path() + "/changes.csv", dir.path() + "/cand.csv");
  EXPECT_EQ(s.changes, 5u);
  EXPECT_EQ(s.seen_changes, 4u);
  EXPECT_EQ(s.candidates, 3u) << "(0,3) is not scored";
  EXPECT_EQ(s.marginal, 1u);
  EXPECT_EQ(s.truth, 5u) << "(0,0), (1,0), (2,0), (0,2) and (1,3)";
  EXPECT_EQ(s.true_positives, 2u);
  EXPECT_NEAR(s.precision, 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(s.recall, 0.4, 1e-12);
  EXPECT_EQ(s.things_truth, 4u);
  EXPECT_EQ(s.things_found, 2u);
  EXPECT_EQ(s.growth_truth, 1u);
  EXPECT_EQ(s.growth_found, 0u);
  ASSERT_EQ(s.false_positives.size(), 1u);
  EXPECT_TRUE(s.false_positives[0] == (TileKey{5, 5}));
  const std::string text = change_score_text(s);
  EXPECT_NE(text.find("precision 0.667, recall 0.400"), std::string::npos) << text;
  EXPECT_NE(text.find("missed: (0,2) (1,3) (2,0)"), std::string::npos) << text;
  // A stricter truth: 100 rays a tile drops the hedge's end (60) from the truth.
  ChangeTruthOptions strict;
  strict.min_rays = 100;
  EXPECT_EQ(score_changes(dir.path() + "/changes.csv", dir.path() + "/cand.csv", strict).truth, 4u);
}

TEST(ChangeScore, NamesTheFileAndLineOfBadInput) {
  TempDir dir;
  write_text(dir.path() + "/changes.csv", kChanges);
  write_text(dir.path() + "/cand.csv", "tx,ty,passes,candidate\n0,0,3,1\n");
  EXPECT_THROW(score_changes(dir.path() + "/changes.csv", dir.path() + "/cand.csv"), pl::Error) << "no changes_seen.csv";
  write_text(dir.path() + "/changes_seen.csv", std::string(kSeen) + "9,1.5,1.5,30\n");
  try {
    score_changes(dir.path() + "/changes.csv", dir.path() + "/cand.csv");
    FAIL() << "no error";
  } catch (const pl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("changes_seen.csv:10: change 9 is not in"), std::string::npos) << e.what();
  }
  write_text(dir.path() + "/changes_seen.csv", std::string(kSeen) + "1,x,1.5,30\n");
  try {
    score_changes(dir.path() + "/changes.csv", dir.path() + "/cand.csv");
    FAIL() << "no error";
  } catch (const pl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("changes_seen.csv:10"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace pl::eval::test
