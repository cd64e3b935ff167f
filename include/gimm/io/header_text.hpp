#pragma once
/// Line-oriented text headers (NRRD, MetaImage): lines, trimming, case folding, and numbers
/// parsed with std::from_chars (exact, whole-token, and independent of the C locale, which
/// would read "0,5" where a header means 0.5). Errors are FormatErrors naming the file and
/// the field.
#include <charconv>
#include <cmath>
#include <cstdint>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <vector>

#include "gimm/core/error.hpp"

namespace gimm::detail {

/// One header line: its text (without the line ending) and where the next line starts.
struct HeaderLine {
  std::string_view text;
  std::size_t next = 0;
  bool complete = false;  ///< ended by '\n' (false: the buffer ended first)
};

/// The line starting at `begin` of `bytes`; "\r\n" and "\n" endings both work.
inline HeaderLine header_line(std::string_view bytes, std::size_t begin) {
  const std::size_t end = bytes.find('\n', begin);
  HeaderLine line;
  line.complete = end != std::string_view::npos;
  const std::size_t stop = line.complete ? end : bytes.size();
  line.text = bytes.substr(begin, stop - begin);
  if (!line.text.empty() && line.text.back() == '\r') line.text.remove_suffix(1);
  line.next = line.complete ? end + 1 : bytes.size();
  return line;
}

inline std::string_view trim(std::string_view s) {
  const auto space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
  while (!s.empty() && space(s.front())) s.remove_prefix(1);
  while (!s.empty() && space(s.back())) s.remove_suffix(1);
  return s;
}

inline std::string lowercase(std::string_view s) {
  std::string out(s);
  for (char& c : out)
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  return out;
}

/// Whitespace-separated words.
inline std::vector<std::string_view> split_words(std::string_view s) {
  std::vector<std::string_view> words;
  for (std::size_t i = 0; i < s.size();) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t')) ++i;
    const std::size_t start = i;
    while (i < s.size() && s[i] != ' ' && s[i] != '\t') ++i;
    if (i > start) words.push_back(s.substr(start, i - start));
  }
  return words;
}

/// A whole token as a T (integer or floating); "nan" and "inf" parse as floating values.
template <class T>
T parse_number(std::string_view token, const std::string& what, const std::string& field) {
  const std::string_view t = trim(token);
  std::string_view digits = t;
  if (!digits.empty() && digits.front() == '+') digits.remove_prefix(1);
  T value{};
  const auto [end, ec] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  GIMM_CHECK_AS(FormatError, !digits.empty() && ec == std::errc() && end == digits.end(),
                "'" << what << "': field '" << field << "': '" << std::string(t) << "' is not "
                    << (std::is_integral_v<T> ? "an integer" : "a number")
                    << (ec == std::errc::result_out_of_range ? " in range" : ""));
  return value;
}

/// Exactly `n` whitespace-separated numbers.
template <class T>
std::vector<T> parse_numbers(std::string_view value, std::size_t n, const std::string& what,
                             const std::string& field) {
  const auto words = split_words(value);
  GIMM_CHECK_AS(FormatError, words.size() == n,
                "'" << what << "': field '" << field << "' must have " << n << " values, got "
                    << words.size() << " ('" << std::string(trim(value)) << "')");
  std::vector<T> out;
  for (const auto& w : words) out.push_back(parse_number<T>(w, what, field));
  return out;
}

}  // namespace gimm::detail
