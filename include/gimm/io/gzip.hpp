#pragma once
/// gzip in memory, on zlib.
///
/// gzip_compress writes one gzip member with mtime 0 and no file name, so equal input gives
/// equal bytes (the dataset pipeline's resume and shard checks compare files byte for byte).
/// gzip_decompress accepts concatenated members (what `cat a.gz b.gz` and some writers make);
/// zlib_decompress reads zlib-wrapped deflate (MetaImage) or gzip.
#include <zlib.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/huge_pages.hpp"

namespace gimm {

inline bool is_gzip(const std::vector<unsigned char>& bytes) {
  return bytes.size() >= 2 && bytes[0] == 0x1f && bytes[1] == 0x8b;
}

namespace detail {
/// Inflates `size` bytes at `data`: zlib's inflate with `window_bits` (15 + 16: gzip, 15 + 32:
/// zlib or gzip, told by the header), streams back to back (another follows when input is left
/// over). `what` names the input in errors; growing past `max_bytes` is an error (a guard
/// against decompression bombs and absurd headers).
inline std::vector<unsigned char> inflate_streams(const unsigned char* data, std::size_t size,
                                                  const std::string& what, std::uint64_t max_bytes,
                                                  int window_bits, const char* format,
                                                  const std::string& limit_reason = "") {
  GIMM_CHECK(size < (1ull << 32), "'" << what << "': compressed data over 4 GiB is not supported");
  z_stream z{};
  GIMM_CHECK_AS(FormatError, inflateInit2(&z, window_bits) == Z_OK,
                "'" << what << "': cannot initialise zlib");
  std::vector<unsigned char> out;
  resize_huge(out,
              std::min<std::uint64_t>(std::max<std::uint64_t>(std::uint64_t(size) * 4, 1 << 16),
                                      std::max<std::uint64_t>(max_bytes, 1)));
  z.next_in = const_cast<unsigned char*>(data);
  z.avail_in = static_cast<uInt>(size);
  std::size_t produced = 0;
  int status = Z_OK;
  for (;;) {
    if (produced == out.size()) {
      if (out.size() >= max_bytes) {
        inflateEnd(&z);
        GIMM_CHECK_AS(FormatError, false,
                      "'" << what << "': " << format << " data inflates to more than " << max_bytes
                          << " bytes" << limit_reason);
      }
      resize_huge(out, std::min<std::uint64_t>(out.size() * 2, max_bytes));
    }
    const std::size_t room = std::min<std::size_t>(out.size() - produced, 1u << 30);
    z.next_out = out.data() + produced;
    z.avail_out = static_cast<uInt>(room);
    status = inflate(&z, Z_NO_FLUSH);
    produced += room - z.avail_out;
    if (status == Z_STREAM_END) {
      if (z.avail_in == 0) break;
      inflateReset(&z);  // another member (stream) follows
      continue;
    }
    if (status == Z_BUF_ERROR && z.avail_in == 0) break;  // input ended mid-stream
    if (status != Z_OK && status != Z_BUF_ERROR) break;
  }
  const std::string message = z.msg ? z.msg : "";
  inflateEnd(&z);
  GIMM_CHECK_AS(FormatError, status == Z_STREAM_END,
                "'" << what << "': " << format << " data is "
                    << (status == Z_BUF_ERROR ? "truncated" : "corrupt: " + message)
                    << " (after inflating " << produced << " bytes)");
  out.resize(produced);
  return out;
}
}  // namespace detail

/// Inflates every gzip member of `bytes`. `what` names the input in errors. Refuses to grow
/// past `max_bytes` (a guard against decompression bombs and absurd headers); `limit_reason`
/// ends that error's message (where the limit comes from).
inline std::vector<unsigned char> gzip_decompress(const std::vector<unsigned char>& bytes,
                                                  const std::string& what,
                                                  std::uint64_t max_bytes = 16ull << 30,
                                                  const std::string& limit_reason = "") {
  return detail::inflate_streams(bytes.data(), bytes.size(), what, max_bytes, 15 + 16, "gzip",
                                 limit_reason);
}

/// The first `n` inflated bytes of gzip data (fewer when it is shorter): reads a header
/// without inflating the rest. Corrupt data within the prefix is an error.
inline std::vector<unsigned char> gzip_prefix(const std::vector<unsigned char>& bytes,
                                              const std::string& what, std::size_t n) {
  GIMM_CHECK(bytes.size() < (1ull << 32),
             "'" << what << "': compressed data over 4 GiB is not supported");
  z_stream z{};
  GIMM_CHECK_AS(FormatError, inflateInit2(&z, 15 + 16) == Z_OK,
                "'" << what << "': cannot initialise zlib");
  std::vector<unsigned char> out(n);
  z.next_in = const_cast<unsigned char*>(bytes.data());
  z.avail_in = static_cast<uInt>(bytes.size());
  z.next_out = out.data();
  z.avail_out = static_cast<uInt>(n);
  int status = Z_OK;
  while (z.avail_out > 0 && status == Z_OK) status = inflate(&z, Z_NO_FLUSH);
  const std::string message = z.msg ? z.msg : "";
  const std::size_t produced = n - z.avail_out;
  inflateEnd(&z);
  GIMM_CHECK_AS(FormatError, status == Z_OK || status == Z_STREAM_END || status == Z_BUF_ERROR,
                "'" << what << "': gzip data is corrupt: " << message);
  out.resize(produced);
  return out;
}

/// Inflates zlib data (RFC 1950: deflate with a 2-byte header and an Adler-32 trailer, what
/// MetaImage's CompressedData holds), or gzip data: the wrapper is told by its first bytes, as
/// MetaIO's own reader does (inflateInit2 with 15 + 32).
inline std::vector<unsigned char> zlib_decompress(const unsigned char* data, std::size_t size,
                                                  const std::string& what,
                                                  std::uint64_t max_bytes = 16ull << 30) {
  return detail::inflate_streams(data, size, what, max_bytes, 15 + 32, "zlib");
}

/// One gzip member of `size` bytes at `data`; level 1 (fast) to 9 (small).
inline std::vector<unsigned char> gzip_compress(const void* data, std::size_t size, int level = 6) {
  GIMM_CHECK(level >= 1 && level <= 9, "gzip_compress: level must be in 1..9, got " << level);
  GIMM_CHECK(size < (1ull << 32), "gzip_compress: input over 4 GiB (" << size << " bytes)");
  z_stream z{};
  GIMM_CHECK(deflateInit2(&z, level, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) == Z_OK,
             "gzip_compress: cannot initialise zlib");
  std::vector<unsigned char> out;
  resize_huge(out, deflateBound(&z, static_cast<uLong>(size)) + 64);
  z.next_in = static_cast<Bytef*>(const_cast<void*>(data));
  z.avail_in = static_cast<uInt>(size);
  z.next_out = out.data();
  z.avail_out = static_cast<uInt>(out.size());
  const int status = deflate(&z, Z_FINISH);
  const std::size_t produced = z.total_out;
  deflateEnd(&z);
  GIMM_CHECK(status == Z_STREAM_END, "gzip_compress: deflate failed (" << status << ")");
  out.resize(produced);
  return out;
}

}  // namespace gimm
