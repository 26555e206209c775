// Checks that a call fails with an InputError naming the expected key (and file), for bad-input tests.
#pragma once
#include <gtest/gtest.h>
#include <string>
#include "core/errors.hpp"

namespace flapstab::testing {

// Runs f; records a failure unless it throws an InputError whose key is `key` and, when `file` is not empty, whose
// file is `file`. Returns the error's message ("" when none was thrown) for further checks.
template <class F>
std::string expect_input_error(F&& f, const std::string& key, const std::string& file = "") {
  try {
    f();
  } catch (const InputError& e) {
    EXPECT_EQ(e.key(), key) << e.what();
    if (!file.empty()) {
      EXPECT_EQ(e.file(), file) << e.what();
    }
    return e.what();
  }
  ADD_FAILURE() << "expected an InputError naming " << key;
  return "";
}

}  // namespace flapstab::testing
