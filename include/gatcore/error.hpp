#pragma once
// gatcore reports every bad input with an exception whose message names the
// offending thing (file, field, index, value). Never a crash or a silent NaN.
#include <sstream>
#include <stdexcept>
#include <string>

namespace gatcore {

struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};
// Input that is malformed: out-of-range index, mismatched shapes, NaN, ...
struct InvalidArgument : Error {
  using Error::Error;
};
// Autodiff misuse, e.g. a saved tensor modified in place before backward().
struct AutogradError : Error {
  using Error::Error;
};

namespace detail {
template <class... Args>
std::string cat(const Args&... args) {
  std::ostringstream os;
  (os << ... << args);
  return os.str();
}
}  // namespace detail

}  // namespace gatcore

// GATCORE_CHECK(cond, msg parts...) throws InvalidArgument with the parts joined.
#define GATCORE_CHECK(cond, ...)                                                \
  do {                                                                          \
    if (!(cond)) throw ::gatcore::InvalidArgument(::gatcore::detail::cat(__VA_ARGS__)); \
  } while (0)
