#pragma once
/// PNG images on libpng: 8- and 16-bit grey, 8-bit RGB; reading any PNG as grey.
///
/// libpng reports errors by longjmp. The setjmp frames below hold only trivial locals and
/// every C++ object they touch lives in the caller, so no destructor is skipped; the message
/// is carried out and thrown as gimm::FormatError/IoError naming the file. Written files carry
/// no timestamp, so equal images give equal bytes.
#include <png.h>
#include <zlib.h>

#include <csetjmp>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "gimm/core/image.hpp"
#include "gimm/io/files.hpp"

namespace gimm {

struct Rgb8 {
  std::uint8_t r = 0, g = 0, b = 0;
  bool operator==(const Rgb8& o) const { return r == o.r && g == o.g && b == o.b; }
};

namespace detail {

struct PngIo {
  std::vector<unsigned char>* buffer = nullptr;  // written bytes, or the bytes being read
  std::size_t read_offset = 0;
  /// Reading: the most decoded bytes the file can hold (checked before allocating them).
  std::size_t max_decoded_bytes = static_cast<std::size_t>(-1);
  char error[256] = {0};
};

/// The most grey bytes a PNG of `file_bytes` can decode to: deflate expands at most 1032:1, and
/// a 1-bit image becomes 8 bits per pixel here; 64 KiB of slack for tiny files.
inline std::size_t png_max_decoded_bytes(std::size_t file_bytes) {
  return file_bytes * 1032 * 8 + (std::size_t{1} << 16);
}

inline void png_on_error(png_structp png, png_const_charp message) {
  auto* io = static_cast<PngIo*>(png_get_error_ptr(png));
  std::strncpy(io->error, message ? message : "unknown libpng error", sizeof(io->error) - 1);
  png_longjmp(png, 1);
}
inline void png_on_warning(png_structp, png_const_charp) {}

inline void png_on_write(png_structp png, png_bytep data, png_size_t size) {
  auto* io = static_cast<PngIo*>(png_get_io_ptr(png));
  io->buffer->insert(io->buffer->end(), data, data + size);
}
inline void png_on_flush(png_structp) {}

inline void png_on_read(png_structp png, png_bytep data, png_size_t size) {
  auto* io = static_cast<PngIo*>(png_get_io_ptr(png));
  if (io->read_offset + size > io->buffer->size()) png_error(png, "PNG data is truncated");
  std::memcpy(data, io->buffer->data() + io->read_offset, size);
  io->read_offset += size;
}

/// Encodes rows (each `row_bytes` long, 16-bit samples in host order) into io.buffer.
/// Returns false with io.error set on failure.
inline bool png_encode(PngIo& io, png_bytep* rows, int height, int width, int bit_depth,
                       int color_type) {
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, &io, png_on_error, png_on_warning);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (!info || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_set_write_fn(png, &io, png_on_write, png_on_flush);
  // The write is on every render's path, so: the Up filter on every row and zlib's run-length
  // strategy at level 1. Measured on a 512 x 320 16-bit DRR and its 8-bit vessel mask
  // (docs/performance.md): 2.5 ms and 0.2 ms against 7.5 and 0.8 ms with libpng's adaptive
  // filters at level 1, and the files come out smaller (232 KB against 238 KB, 1.8 against 3.0 KB).
  png_set_compression_level(png, 1);
  png_set_compression_strategy(png, Z_RLE);
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_UP);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height),
               bit_depth, color_type, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (bit_depth == 16) png_set_swap(png);  // PNG is big-endian; our samples are little-endian
  png_write_image(png, rows);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

template <class T>
void write_png_rows(const std::filesystem::path& path, const Image<T>& image, int bit_depth,
                    int color_type) {
  GIMM_CHECK(!image.empty(), "write_png: '" << path.string() << "': the image is empty ("
                                            << image.rows() << " x " << image.cols() << ")");
  std::vector<png_bytep> rows(static_cast<std::size_t>(image.rows()));
  for (int r = 0; r < image.rows(); ++r)
    rows[r] =
        reinterpret_cast<png_bytep>(const_cast<T*>(image.data() + std::size_t(r) * image.cols()));
  std::vector<unsigned char> bytes;
  PngIo io;
  io.buffer = &bytes;
  GIMM_CHECK_AS(IoError,
                png_encode(io, rows.data(), image.rows(), image.cols(), bit_depth, color_type),
                "cannot encode PNG '" << path.string() << "': " << io.error);
  write_file_atomic(path, bytes.data(), bytes.size());
}

struct PngDecoded {
  int rows = 0, cols = 0, bit_depth = 0;
  std::vector<unsigned char> pixels;  // grey samples, 1 or 2 bytes each (host order)
};

/// Decodes any PNG to one grey channel (colour by libpng's rgb_to_gray, alpha stripped,
/// palettes and low bit depths expanded to 8 bits).
inline bool png_decode(PngIo& io, PngDecoded& out) {
  png_structp png =
      png_create_read_struct(PNG_LIBPNG_VER_STRING, &io, png_on_error, png_on_warning);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (!info || setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  png_set_read_fn(png, &io, png_on_read);
  png_set_user_limits(png, 1u << 15, 1u << 15);
  png_read_info(png, info);
  const int color = png_get_color_type(png, info);
  if (color == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (color == PNG_COLOR_TYPE_GRAY && png_get_bit_depth(png, info) < 8)
    png_set_expand_gray_1_2_4_to_8(png);
  if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
  if (color & PNG_COLOR_MASK_COLOR || color == PNG_COLOR_TYPE_PALETTE)
    png_set_rgb_to_gray_fixed(png, 1, -1, -1);
  png_set_strip_alpha(png);
  if (png_get_bit_depth(png, info) == 16) png_set_swap(png);
  // Adam7-interlaced files: libpng de-interlaces when asked and every row is read once per pass.
  const int passes = png_set_interlace_handling(png);
  png_read_update_info(png, info);
  out.rows = static_cast<int>(png_get_image_height(png, info));
  out.cols = static_cast<int>(png_get_image_width(png, info));
  out.bit_depth = png_get_bit_depth(png, info);
  const std::size_t row_bytes = png_get_rowbytes(png, info);
  if (row_bytes != static_cast<std::size_t>(out.cols) * (out.bit_depth / 8))
    png_error(png, "unexpected row size after conversion to grey");
  if (row_bytes > io.max_decoded_bytes / static_cast<std::size_t>(out.rows))
    png_error(png, "its header's image size is more than its compressed data can hold");
  out.pixels.resize(row_bytes * static_cast<std::size_t>(out.rows));
  for (int pass = 0; pass < passes; ++pass)
    for (int r = 0; r < out.rows; ++r)
      png_read_row(png, out.pixels.data() + row_bytes * r, nullptr);
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

/// ", header W x H px (gimm reads up to 32768 a side)" from the IHDR chunk's own bytes (libpng
/// refuses a bad size before it tells it), or "" when the file has no IHDR where it belongs.
inline std::string png_header_size(const std::vector<unsigned char>& bytes) {
  if (bytes.size() < 24 || std::memcmp(bytes.data() + 12, "IHDR", 4) != 0) return {};
  const auto be32 = [&](std::size_t at) {
    return (std::uint32_t(bytes[at]) << 24) | (std::uint32_t(bytes[at + 1]) << 16) |
           (std::uint32_t(bytes[at + 2]) << 8) | std::uint32_t(bytes[at + 3]);
  };
  return ", header " + std::to_string(be32(16)) + " x " + std::to_string(be32(20)) +
         " px (gimm reads up to 32768 a side)";
}

inline PngDecoded read_png_any(const std::filesystem::path& path) {
  std::vector<unsigned char> bytes = read_file_bytes(path);
  GIMM_CHECK_AS(FormatError, bytes.size() >= 8 && png_sig_cmp(bytes.data(), 0, 8) == 0,
                "'" << path.string() << "' is not a PNG file (bad signature)");
  PngIo io;
  io.buffer = &bytes;
  io.max_decoded_bytes = png_max_decoded_bytes(bytes.size());
  PngDecoded out;
  GIMM_CHECK_AS(FormatError, png_decode(io, out),
                "cannot decode PNG '" << path.string() << "' (" << bytes.size() << " bytes"
                                      << png_header_size(bytes) << "): " << io.error);
  GIMM_CHECK_AS(FormatError, out.rows > 0 && out.cols > 0,
                "'" << path.string() << "' is an empty image");
  return out;
}

}  // namespace detail

inline void write_png(const std::filesystem::path& path, const Image<std::uint8_t>& image) {
  detail::write_png_rows(path, image, 8, PNG_COLOR_TYPE_GRAY);
}
inline void write_png(const std::filesystem::path& path, const Image<std::uint16_t>& image) {
  detail::write_png_rows(path, image, 16, PNG_COLOR_TYPE_GRAY);
}
inline void write_png(const std::filesystem::path& path, const Image<Rgb8>& image) {
  static_assert(sizeof(Rgb8) == 3, "Rgb8 must be packed");
  detail::write_png_rows(path, image, 8, PNG_COLOR_TYPE_RGB);
}

/// Reads a PNG as 16-bit grey (8-bit samples v become v * 257, so full scale stays full).
inline Image<std::uint16_t> read_png16(const std::filesystem::path& path) {
  const detail::PngDecoded d = detail::read_png_any(path);
  Image<std::uint16_t> image(d.rows, d.cols);
  if (d.bit_depth == 16) {
    std::memcpy(image.data(), d.pixels.data(), d.pixels.size());
  } else {
    for (std::size_t p = 0; p < image.size(); ++p) image.data()[p] = d.pixels[p] * 257;
  }
  return image;
}

/// Reads a PNG as 8-bit grey (16-bit samples are rounded: (v + 128) / 257).
inline Image<std::uint8_t> read_png8(const std::filesystem::path& path) {
  const Image<std::uint16_t> wide = read_png16(path);
  Image<std::uint8_t> image(wide.rows(), wide.cols());
  for (std::size_t p = 0; p < image.size(); ++p)
    image.data()[p] = static_cast<std::uint8_t>((wide.data()[p] + 128u) / 257u);
  return image;
}

/// Reads a PNG as grey in [0, 1]: samples divided by their bit depth's full scale (255 or
/// 65535), so an 8-bit and a 16-bit copy of one picture give the same values to within 1/255.
inline Image<float> read_png_unit(const std::filesystem::path& path) {
  // v * 257 / 65535 and v / 255 are the same real number, so both round to the same float.
  const Image<std::uint16_t> wide = read_png16(path);
  Image<float> image(wide.rows(), wide.cols());
  for (std::size_t p = 0; p < image.size(); ++p) image.data()[p] = float(wide.data()[p]) / 65535.0f;
  return image;
}

}  // namespace gimm
