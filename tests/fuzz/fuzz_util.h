// Shared by the libFuzzer targets. A target passes each input to the product and accepts only
// the documented outcomes: a value, or a km::Error (analysis/core/errors.h) refusing the input.
// Any other exception, a failed invariant or a sanitizer report is a finding: the process aborts
// and libFuzzer saves the input.
#pragma once

#include <cxxabi.h>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <string_view>
#include <typeinfo>

#include "analysis/core/errors.h"

namespace km::fuzz {

inline std::string_view AsText(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

// Aborts with a message when an invariant of the product does not hold.
inline std::string TypeName(const std::type_info& t) {
  int status = 0;
  char* name = abi::__cxa_demangle(t.name(), nullptr, nullptr, &status);
  std::string out = status == 0 && name ? name : t.name();
  std::free(name);
  return out;
}

[[noreturn]] inline void Fail(const std::string& what) {
  std::fprintf(stderr, "kinemetric fuzz finding: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();
}

inline void Check(bool ok, const char* what) {
  if (!ok) Fail(std::string("invariant violated: ") + what);
}

// Runs body(); a km::Error is the documented refusal of bad input and ends the input normally.
// Returns true when body() completed without throwing.
template <typename Body>
bool Guarded(Body&& body) {
  try {
    body();
    return true;
  } catch (const Error&) {
    return false;
  } catch (const std::exception& e) {
    Fail(std::string("undocumented exception ") + TypeName(typeid(e)) + ": " + e.what());
  } catch (...) {
    Fail("undocumented exception of a non-std type");
  }
}

}  // namespace km::fuzz
