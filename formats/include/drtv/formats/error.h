// drtv/formats/error.h — error values for bad input, and check macros for bugs.
//
// Two kinds of failure never mix (STYLE.md, "Errors: bug != bad input"):
//  - Bad input (a file, a flag, a sector's bytes) is returned as an `Error` whose message names
//    the file, the part of it and, where it applies, the byte offset, e.g.
//    "worlds/island.drtv: sector (3,-1): probe 12 at byte 1864: flags 0x80 unknown".
//  - A broken contract inside drtv is a bug: DRTV_CHECK prints both operands and aborts.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <expected>
#include <sstream>
#include <string>
#include <utility>

namespace drtv {

// A description of what is wrong with some input, for a person to read. The message is complete:
// callers prepend context ("file: ") with `Error::context`, never parse it.
struct Error {
  std::string message;

  // Returns a copy with "prefix: " in front of the message.
  [[nodiscard]] Error context(const std::string& prefix) const { return Error{prefix + ": " + message}; }
};

// A value or the Error that explains why there is none.
template <class T>
using Result = std::expected<T, Error>;

// Shorthand for returning an error: `return fail("bad magic")`.
inline std::unexpected<Error> fail(std::string message) { return std::unexpected(Error{std::move(message)}); }

namespace detail {
[[noreturn]] inline void checkFailed(const char* file, int line, const char* expr, const std::string& values) {
  std::fprintf(stderr, "drtv: internal error (bug) at %s:%d: check failed: %s%s\n", file, line, expr, values.c_str());
  std::abort();
}
template <class A, class B>
std::string operands(const A& a, const B& b) {
  std::ostringstream s;
  s << " (" << a << " vs " << b << ")";
  return s.str();
}
}  // namespace detail

}  // namespace drtv

// Checks an invariant that only a bug can break. Always on, also in Release builds.
#define DRTV_CHECK(cond) \
  do { if (!(cond)) ::drtv::detail::checkFailed(__FILE__, __LINE__, #cond, ""); } while (0)
#define DRTV_CHECK_OP(a, op, b)                                                              \
  do {                                                                                        \
    const auto& drtv_a_ = (a);                                                                \
    const auto& drtv_b_ = (b);                                                                \
    if (!(drtv_a_ op drtv_b_))                                                                \
      ::drtv::detail::checkFailed(__FILE__, __LINE__, #a " " #op " " #b,                      \
                                  ::drtv::detail::operands(drtv_a_, drtv_b_));               \
  } while (0)
#define DRTV_CHECK_EQ(a, b) DRTV_CHECK_OP(a, ==, b)
#define DRTV_CHECK_LE(a, b) DRTV_CHECK_OP(a, <=, b)
#define DRTV_CHECK_LT(a, b) DRTV_CHECK_OP(a, <, b)
