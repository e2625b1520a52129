// Typed errors shared by every layer. A library function returns a value or throws one of
// these; api/ maps each type to one HTTP status in one place, the CLI to one exit status.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <string>

namespace km {

// Base of every error the product raises on purpose.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The input (a file, a request, a parameter) is wrong. Names where: file, line, field.
// line == 0 means "not tied to one line" (e.g. a missing header key).
class InvalidInput : public Error {
 public:
  InvalidInput(std::string file, std::size_t line, std::string field, std::string reason);
  explicit InvalidInput(std::string reason) : InvalidInput("", 0, "", std::move(reason)) {}

  const std::string& file() const { return file_; }
  std::size_t line() const { return line_; }
  const std::string& field() const { return field_; }
  const std::string& reason() const { return reason_; }

 private:
  std::string file_;
  std::size_t line_;
  std::string field_;
  std::string reason_;
};

// The input is larger than the configured limit.
class TooLarge : public InvalidInput {
 public:
  using InvalidInput::InvalidInput;
};

// A quantity cannot be determined from the data (rank deficiency, counting condition).
class NotObservable : public Error {
 public:
  using Error::Error;
};

// An iterative solver did not reach its tolerance (e.g. forward kinematics near a singularity).
class DidNotConverge : public Error {
 public:
  using Error::Error;
};

// A requested record does not exist.
class NotFound : public Error {
 public:
  using Error::Error;
};

// The service is busy (a queue is full); the same request may succeed a little later.
class Unavailable : public Error {
 public:
  using Error::Error;
};

// Runs f(); an InvalidInput it throws without a file is thrown again naming `file` (its line,
// field and reason kept), so that an error found in the analysis of a file names that file.
template <class F>
auto InFile(const std::string& file, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const InvalidInput& e) {
    if (!e.file().empty() || dynamic_cast<const TooLarge*>(&e) != nullptr) throw;
    throw InvalidInput(file, e.line(), e.field(), e.reason());
  }
}

}  // namespace km
