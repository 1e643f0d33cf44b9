#pragma once
// The InputError that loading some input throws, for tests of what users write: the error is then
// checked for its file, line, field and words.

#include <functional>
#include <string>

#include <gtest/gtest.h>

#include "config/input_error.h"

namespace occmap::testing {

inline InputError errorOf(const std::function<void()>& load) {
  try {
    load();
  } catch (const InputError& error) {
    return error;
  }
  ADD_FAILURE() << "the input was accepted but should be refused";
  return InputError("", 0, "", "");
}

inline bool says(const InputError& error, const std::string& text) {
  return std::string(error.what()).find(text) != std::string::npos;
}

}  // namespace occmap::testing
