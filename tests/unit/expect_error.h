// Test helpers: the error a call must raise, and substring checks on its message.
#pragma once

#include <gtest/gtest.h>

#include <exception>
#include <stdexcept>
#include <string>

namespace km::test {

// Runs f and returns the E it throws; a failure when it throws something else or nothing.
template <typename E, typename F>
E Expect(F f) {
  try {
    f();
  } catch (const E& e) {
    return e;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "unexpected error: " << e.what();
    throw;
  }
  ADD_FAILURE() << "accepted";
  throw std::runtime_error("accepted");
}

inline bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

}  // namespace km::test
