#pragma once
/// Errors and checks.
///
/// GIMM_CHECK(cond, msg) is always on: on failure it throws gimm::Error (or the named subclass
/// with GIMM_CHECK_AS) whose message starts with "gimm: " and streams `msg`, which must name
/// the input and show the bad value:
///   GIMM_CHECK(n >= 8, "fundamental_8pt: need at least 8 correspondences, got " << n);
/// GIMM_ASSERT(cond) guards internal invariants and is compiled out when NDEBUG is set.
/// Never use GIMM_ASSERT on user input.
#include <cassert>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>

namespace gimm {

/// `text` safe to print on a terminal: control bytes (a header's ESC or BEL, a NUL that would
/// cut the message short) and DEL as \xNN; newlines and tabs stay.
inline std::string printable(std::string_view text) {
  static const char* const hex = "0123456789abcdef";
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    const auto byte = static_cast<unsigned char>(c);
    if ((byte < 0x20 && c != '\n' && c != '\t') || byte == 0x7f) {
      out += "\\x";
      out += hex[byte >> 4];
      out += hex[byte & 15];
    } else {
      out += c;
    }
  }
  return out;
}

/// Base of every exception gimm throws. Its message is printable(): bytes quoted from a bad
/// input cannot drive the terminal or end the message early.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what) : std::runtime_error(printable(what)) {}
};

/// A file or stream could not be opened, read or written.
class IoError : public Error {
 public:
  using Error::Error;
};

/// An output could not be written (a full disk, no permission, something in the way). Unlike a
/// bad input, which spoils one item, it spoils every output after it: a run that records a bad
/// item and goes on (gimm-dataset's patients) stops at this one.
class WriteError : public IoError {
 public:
  using IoError::IoError;
};

/// A file was opened but its content is malformed (bad magic, truncated, bad header).
class FormatError : public Error {
 public:
  using Error::Error;
};

namespace detail {
template <class E>
[[noreturn]] inline void throw_with_prefix(const std::string& message) {
  throw E("gimm: " + message);
}
}  // namespace detail

}  // namespace gimm

#define GIMM_CHECK_AS(ErrorType, cond, msg)                                   \
  do {                                                                        \
    if (!(cond)) {                                                            \
      std::ostringstream gimm_check_stream_;                                  \
      gimm_check_stream_ << msg;                                              \
      ::gimm::detail::throw_with_prefix<ErrorType>(gimm_check_stream_.str()); \
    }                                                                         \
  } while (false)

#define GIMM_CHECK(cond, msg) GIMM_CHECK_AS(::gimm::Error, cond, msg)

/// Throws unconditionally (for unreachable-on-valid-input branches that depend on user input).
#define GIMM_FAIL(msg) GIMM_CHECK(false, msg)

#define GIMM_ASSERT(cond) assert(cond)
