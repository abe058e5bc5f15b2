// gzip of whole buffers: what goes in comes out, a stream cut short or not gzip at all is an
// error, and a body that inflates beyond its limit is refused as too large (a gzip bomb).
#include <gtest/gtest.h>

#include <string>

#include "pl/common/gzip.hpp"

TEST(Gzip, RoundTripsAndRefusesWhatIsNotAWholeStream) {
  std::string text;
  for (int i = 0; i < 20000; ++i) text += "{\"x\": " + std::to_string(i % 97) + "}, ";
  for (int level : {1, 9}) {
    const std::string gz = pl::gzip(text, level);
    EXPECT_LT(gz.size() * 5, text.size());
    EXPECT_EQ(pl::gunzip(gz, text.size()), text);
    EXPECT_THROW(pl::gunzip(gz.substr(0, gz.size() / 2), text.size()), pl::Error);
    EXPECT_THROW(pl::gunzip(gz, text.size() - 1), pl::GzipTooLarge);
  }
  EXPECT_EQ(pl::gunzip(pl::gzip(""), 0), "");
  EXPECT_THROW(pl::gunzip("not gzip at all", 1 << 20), pl::Error);
  // A bomb: 64 MiB of zeros in a few kB, refused at a 1 MiB limit without inflating it all.
  const std::string bomb = pl::gzip(std::string(std::size_t{64} << 20, '\0'), 9);
  EXPECT_LT(bomb.size(), std::size_t{100} << 10);
  EXPECT_THROW(pl::gunzip(bomb, std::size_t{1} << 20), pl::GzipTooLarge);
}
