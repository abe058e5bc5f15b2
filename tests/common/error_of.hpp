// The message of the pl::Error a piece of test code throws, for tests that check what it says.
#pragma once

#include <string>

#include "pl/common/error.hpp"

namespace pl::test {

// The message of the pl::Error that `f` throws ("" when it does not throw one).
template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const pl::Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace pl::test
