#pragma once
/// NumPy .npy arrays (format version 1.0, C order, little-endian), so Python reads gimm's
/// float images with one call: numpy.load("x.npy").
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "gimm/core/image.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/header_text.hpp"

namespace gimm {

namespace detail {
template <class T>
constexpr const char* npy_descr() {
  if constexpr (std::is_same_v<T, float>) return "<f4";
  if constexpr (std::is_same_v<T, double>) return "<f8";
  if constexpr (std::is_same_v<T, std::uint8_t>) return "|u1";
  if constexpr (std::is_same_v<T, std::uint16_t>) return "<u2";
  if constexpr (std::is_same_v<T, std::int32_t>) return "<i4";
  if constexpr (std::is_same_v<T, std::int64_t>) return "<i8";
  return nullptr;
}

inline std::string npy_shape(const std::vector<std::int64_t>& shape) {
  std::string s = "(";
  for (std::size_t a = 0; a < shape.size(); ++a) s += std::to_string(shape[a]) + ", ";
  if (shape.size() > 1) s.resize(s.size() - 2);  // numpy writes "(3,)" but "(3, 4)"
  if (shape.size() == 1) s.resize(s.size() - 1);
  return s + ")";
}
}  // namespace detail

/// Writes `count` values at `data` as an array of `shape` (C order), atomically.
template <class T>
void write_npy(const std::filesystem::path& path, const T* data,
               const std::vector<std::int64_t>& shape) {
  static_assert(detail::npy_descr<T>() != nullptr, "write_npy: unsupported element type");
  std::int64_t count = 1;
  for (const auto n : shape) {
    GIMM_CHECK(n >= 0, "write_npy: '" << path.string() << "': negative dimension " << n);
    count *= n;
  }
  std::string header = std::string("{'descr': '") + detail::npy_descr<T>() +
                       "', 'fortran_order': False, 'shape': " + detail::npy_shape(shape) + ", }";
  // Magic (6) + version (2) + length (2) + header + '\n' is padded to a multiple of 64.
  const std::size_t unpadded = 10 + header.size() + 1;
  header.append((64 - unpadded % 64) % 64, ' ');
  header += '\n';
  std::string bytes("\x93NUMPY\x01\x00", 8);
  bytes += static_cast<char>(header.size() & 0xff);
  bytes += static_cast<char>(header.size() >> 8);
  bytes += header;
  bytes.append(reinterpret_cast<const char*>(data), static_cast<std::size_t>(count) * sizeof(T));
  write_file_atomic(path, bytes);
}

template <class T>
void write_npy(const std::filesystem::path& path, const Image<T>& image) {
  write_npy(path, image.data(), {image.rows(), image.cols()});
}

namespace detail {
/// The extents of an NPY shape tuple's inside ("3, 4" or "5," or ""): non-negative decimal
/// integers (parse_number checks the range); anything else is an error naming the file.
inline std::vector<std::uint64_t> npy_shape_extents(std::string_view inside,
                                                    const std::string& what) {
  std::vector<std::uint64_t> out;
  for (std::string_view rest = trim(inside); !rest.empty();) {
    const std::size_t comma = rest.find(',');
    const std::string_view token = trim(rest.substr(0, comma));
    GIMM_CHECK_AS(
        FormatError, !token.empty() && token.find_first_not_of("0123456789") == std::string::npos,
        "'" << what << "': shape (" << std::string(inside) << ") is not a tuple of integers");
    out.push_back(parse_number<std::uint64_t>(token, what, "shape"));
    rest = comma == std::string_view::npos ? std::string_view() : trim(rest.substr(comma + 1));
  }
  return out;
}
}  // namespace detail

/// Reads a 2D .npy of element type T (exactly; no conversion) into an Image.
template <class T>
Image<T> read_npy_image(const std::filesystem::path& path) {
  const std::string what = path.string();
  const auto bytes = read_file_bytes(path);
  GIMM_CHECK_AS(FormatError, bytes.size() >= 10 && std::memcmp(bytes.data(), "\x93NUMPY", 6) == 0,
                "'" << what << "': not a .npy file (bad magic)");
  GIMM_CHECK_AS(FormatError, bytes[6] == 1,
                "'" << what << "': .npy version " << int(bytes[6]) << " is not supported");
  const std::size_t header_size = bytes[8] | (bytes[9] << 8);
  GIMM_CHECK_AS(FormatError, bytes.size() >= 10 + header_size,
                "'" << what << "': truncated header");
  const std::string header(bytes.begin() + 10, bytes.begin() + 10 + header_size);
  const std::string descr = std::string("'descr': '") + detail::npy_descr<T>() + "'";
  GIMM_CHECK_AS(
      FormatError, header.find(descr) != std::string::npos,
      "'" << what << "': element type is not " << detail::npy_descr<T>() << ": " << header);
  GIMM_CHECK_AS(FormatError, header.find("'fortran_order': False") != std::string::npos,
                "'" << what << "': Fortran-order arrays are not supported");
  const auto open = header.find("'shape': (");
  GIMM_CHECK_AS(FormatError, open != std::string::npos, "'" << what << "': no shape: " << header);
  const auto close = header.find(')', open);
  GIMM_CHECK_AS(FormatError, close != std::string::npos,
                "'" << what << "': unterminated shape: " << header);
  const std::vector<std::uint64_t> shape =
      detail::npy_shape_extents(header.substr(open + 10, close - open - 10), what);
  GIMM_CHECK_AS(FormatError, shape.size() == 2,
                "'" << what << "': expected a 2D shape (rows, cols), got "
                    << header.substr(open + 9, close - open - 8));
  const std::uint64_t rows = shape[0], cols = shape[1];
  // A gimm image has pixels (and copying zero of them from a null buffer is undefined).
  GIMM_CHECK_AS(FormatError, rows > 0 && cols > 0,
                "'" << what << "': shape (" << rows << ", " << cols << ") has no pixels");
  constexpr std::uint64_t kMaxSide = std::numeric_limits<int>::max();
  GIMM_CHECK_AS(FormatError, rows <= kMaxSide && cols <= kMaxSide,
                "'" << what << "': shape (" << rows << ", " << cols << ") exceeds " << kMaxSide
                    << " per side");
  // The data size is checked against the file before the image is allocated.
  const std::uint64_t data_bytes = bytes.size() - 10 - header_size;
  // Compared by division, so a huge shape cannot overflow the product.
  GIMM_CHECK_AS(
      FormatError,
      cols == 0 ? data_bytes == 0
                : data_bytes % (sizeof(T) * cols) == 0 && data_bytes / (sizeof(T) * cols) == rows,
      "'" << what << "': data size " << data_bytes << " bytes does not match shape (" << rows
          << ", " << cols << ")");
  Image<T> image(static_cast<int>(rows), static_cast<int>(cols));
  const std::size_t payload = image.size() * sizeof(T);
  std::memcpy(image.data(), bytes.data() + 10 + header_size, payload);
  return image;
}

}  // namespace gimm
