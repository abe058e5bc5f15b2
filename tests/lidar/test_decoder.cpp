// The options every decoder shares.
#include <gtest/gtest.h>

#include "pl/common/error.hpp"
#include "pl/lidar/decoder.hpp"

namespace pl::lidar {
namespace {

TEST(LidarDecoder, OptionsNameTheFieldThatIsWrong) {
  DecoderOptions o;
  EXPECT_NO_THROW(o.validate());
  o.max_range_m = 0.1;
  try {
    o.validate();
    FAIL() << "a range limit below the minimum was taken";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("max_range_m"), std::string::npos) << e.what();
  }
  o = {};
  o.cut_azimuth_deg = 360;
  EXPECT_THROW(o.validate(), Error);
}

}  // namespace
}  // namespace pl::lidar
