#pragma once
/// safetensors files (Hugging Face): an 8-byte little-endian u64 header length N, N bytes of
/// UTF-8 JSON mapping tensor name -> {"dtype", "shape", "data_offsets": [begin, end]} (offsets
/// relative to the data section) plus an optional "__metadata__" object of strings, then the raw
/// little-endian tensor bytes.
///
/// The reader treats the file as hostile: every number in the header is checked against the file
/// before any tensor byte is touched, so a bad file is a gimm::FormatError naming the source and
/// the offending tensor/value, never an out-of-bounds read. The writer stores float32 only.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/io/files.hpp"
#include "gimm/nn/tensor.hpp"

namespace gimm::nn {

struct SafetensorsEntry {
  std::string name, dtype;
  nn::Shape shape;
  std::uint64_t begin = 0, end = 0;  ///< byte range within the data section
};

namespace detail {

/// Tensor bytes are copied with memcpy, which is only right on a little-endian host.
inline void require_little_endian() {
#if defined(__BYTE_ORDER__) && defined(__ORDER_LITTLE_ENDIAN__)
  static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
                "gimm/nn/safetensors.hpp: safetensors data is little-endian; this host is not");
#else
  const std::uint16_t one = 1;
  unsigned char low;
  std::memcpy(&low, &one, 1);
  GIMM_CHECK(low == 1, "safetensors: only little-endian hosts are supported");
#endif
}

/// Bytes per element of a safetensors dtype; 0 for a dtype gimm does not know.
inline std::size_t safetensors_dtype_size(const std::string& dtype) {
  static const std::map<std::string, std::size_t> sizes = {
      {"BOOL", 1}, {"U8", 1},  {"I8", 1},  {"F8_E5M2", 1}, {"F8_E4M3", 1},
      {"I16", 2},  {"U16", 2}, {"F16", 2}, {"BF16", 2},    {"I32", 4},
      {"U32", 4},  {"F32", 4}, {"F64", 8}, {"I64", 8},     {"U64", 8}};
  const auto it = sizes.find(dtype);
  return it == sizes.end() ? 0 : it->second;
}

/// IEEE half -> float; exact, since every half (subnormals, inf, NaN included) is a float.
inline float half_to_float(std::uint16_t h) {
  const std::uint32_t sign = std::uint32_t(h & 0x8000u) << 16;
  const std::uint32_t exponent = (h >> 10) & 0x1fu, mantissa = h & 0x3ffu;
  if (exponent == 0) {  // zero or subnormal: mantissa * 2^-24
    const float magnitude = std::ldexp(static_cast<float>(mantissa), -24);
    return sign ? -magnitude : magnitude;
  }
  const std::uint32_t bits = exponent == 31 ? sign | 0x7f800000u | (mantissa << 13)
                                            : sign | ((exponent + 112) << 23) | (mantissa << 13);
  float f;
  std::memcpy(&f, &bits, 4);
  return f;
}

/// bfloat16 is the top half of a float.
inline float bf16_to_float(std::uint16_t h) {
  const std::uint32_t bits = std::uint32_t(h) << 16;
  float f;
  std::memcpy(&f, &bits, 4);
  return f;
}

}  // namespace detail

class SafetensorsFile {
 public:
  /// Reads the whole file; a missing file is a gimm::IoError naming the path.
  static SafetensorsFile load(const std::string& path) {
    return parse(read_file_bytes(path), path);
  }

  /// Validates `bytes` as a safetensors file; `source` names it in every error message.
  static SafetensorsFile parse(std::vector<std::uint8_t> bytes, const std::string& source) {
    detail::require_little_endian();
    SafetensorsFile file;
    file.source_ = source;
    const std::string where = "safetensors '" + source + "': ";
    GIMM_CHECK_AS(
        FormatError, bytes.size() >= 8,
        where << "file is " << bytes.size() << " bytes, shorter than the 8-byte header length");
    std::uint64_t header_size = 0;
    for (int i = 7; i >= 0; --i) header_size = (header_size << 8) | bytes[std::size_t(i)];
    const std::uint64_t after = bytes.size() - 8;
    // The reference implementation's limit; real headers are a few MB at most.
    constexpr std::uint64_t kMaxHeader = 100'000'000;
    GIMM_CHECK_AS(FormatError, header_size > 0, where << "header length is 0");
    GIMM_CHECK_AS(
        FormatError, header_size <= kMaxHeader,
        where << "header length " << header_size << " is absurd (limit " << kMaxHeader << ")");
    GIMM_CHECK_AS(FormatError, header_size <= after,
                  where << "header length " << header_size << " exceeds the " << after
                        << " bytes after the length field");
    const std::uint64_t data_size = after - header_size;
    file.data_start_ = 8 + static_cast<std::size_t>(header_size);

    const nlohmann::json header = parse_header(bytes, file.data_start_, where);
    GIMM_CHECK_AS(FormatError, header.is_object(),
                  where << "header is not a JSON object (got " << header.type_name() << ")");

    std::vector<const SafetensorsEntry*> by_offset;
    for (const auto& [name, value] : header.items()) {
      if (name == "__metadata__") {
        GIMM_CHECK_AS(FormatError, value.is_object(),
                      where << "__metadata__ is not an object (got " << value.type_name() << ")");
        for (const auto& [key, text] : value.items()) {
          GIMM_CHECK_AS(
              FormatError, text.is_string(),
              where << "__metadata__ value of '" << key << "' is not a string: " << text.dump());
          file.metadata_[key] = text.get<std::string>();
        }
        continue;
      }
      SafetensorsEntry entry = parse_entry(name, value, data_size, where);
      by_offset.push_back(&file.entries_.emplace(name, std::move(entry)).first->second);
    }

    // The spec requires the tensors to tile the data section exactly: no overlap (aliasing
    // tensors) and no uncovered bytes (room to smuggle data), so both are errors here.
    std::sort(by_offset.begin(), by_offset.end(), [](const auto* a, const auto* b) {
      return std::tie(a->begin, a->end) < std::tie(b->begin, b->end);
    });
    std::uint64_t covered = 0;
    const SafetensorsEntry* previous = nullptr;
    for (const SafetensorsEntry* e : by_offset) {
      GIMM_CHECK_AS(FormatError, e->begin >= covered,
                    where << "tensors '" << previous->name << "' [" << previous->begin << ", "
                          << previous->end << "] and '" << e->name << "' [" << e->begin << ", "
                          << e->end << "] overlap");
      GIMM_CHECK_AS(FormatError, e->begin == covered,
                    where << "data bytes [" << covered << ", " << e->begin
                          << ") are not covered by any tensor");
      covered = e->end;
      previous = e;
    }
    GIMM_CHECK_AS(FormatError, covered == data_size,
                  where << "data bytes [" << covered << ", " << data_size
                        << ") are not covered by any tensor");
    file.bytes_ = std::move(bytes);
    return file;
  }

  const std::string& source() const { return source_; }
  const std::map<std::string, std::string>& metadata() const { return metadata_; }

  /// Tensor names, sorted.
  std::vector<std::string> names() const {
    std::vector<std::string> out;
    for (const auto& kv : entries_) out.push_back(kv.first);
    return out;
  }
  bool contains(const std::string& name) const { return entries_.count(name) != 0; }

  const SafetensorsEntry& entry(const std::string& name) const {
    const auto it = entries_.find(name);
    GIMM_CHECK_AS(FormatError, it != entries_.end(),
                  "safetensors '" << source_ << "': no tensor '" << name << "'");
    return it->second;
  }

  /// The tensor as float32: F32 copied, F16 and BF16 exact, F64 rounded to nearest (a finite
  /// value beyond the float range is an error rather than a silent inf). Other dtypes throw.
  nn::Tensor tensor(const std::string& name) const {
    const SafetensorsEntry& e = entry(name);
    GIMM_CHECK_AS(FormatError,
                  e.dtype == "F32" || e.dtype == "F16" || e.dtype == "BF16" || e.dtype == "F64",
                  "safetensors '" << source_ << "': tensor '" << name << "' has dtype " << e.dtype
                                  << "; only F32, F16, BF16 and F64 convert to float32");
    const unsigned char* src = bytes_.data() + data_start_ + e.begin;
    const std::size_t n =
        static_cast<std::size_t>(e.end - e.begin) / detail::safetensors_dtype_size(e.dtype);
    std::vector<float> values(n);
    if (e.dtype == "F32") {
      if (n) std::memcpy(values.data(), src, 4 * n);
    } else if (e.dtype == "F16" || e.dtype == "BF16") {
      const bool half = e.dtype == "F16";
      for (std::size_t i = 0; i < n; ++i) {
        std::uint16_t h;
        std::memcpy(&h, src + 2 * i, 2);
        values[i] = half ? detail::half_to_float(h) : detail::bf16_to_float(h);
      }
    } else {  // F64
      for (std::size_t i = 0; i < n; ++i) {
        double d;
        std::memcpy(&d, src + 8 * i, 8);
        GIMM_CHECK_AS(FormatError,
                      !std::isfinite(d) || std::fabs(d) <= std::numeric_limits<float>::max(),
                      "safetensors '" << source_ << "': tensor '" << name << "': F64 value " << d
                                      << " at index " << i << " is outside the float32 range");
        values[i] = static_cast<float>(d);
      }
    }
    return nn::Tensor(e.shape, std::move(values));
  }

  /// As tensor(name), and throws unless the stored shape is exactly `expected`.
  nn::Tensor tensor(const std::string& name, const nn::Shape& expected) const {
    const SafetensorsEntry& e = entry(name);
    GIMM_CHECK_AS(FormatError, e.shape == expected,
                  "safetensors '" << source_ << "': tensor '" << name << "' has shape "
                                  << nn::shape_string(e.shape) << ", expected "
                                  << nn::shape_string(expected));
    return tensor(name);
  }

  /// Throws unless the file holds exactly the tensors `expected` (any order), listing the
  /// missing and the extra names.
  void expect_names(const std::vector<std::string>& expected) const {
    const std::set<std::string> want(expected.begin(), expected.end());
    std::string missing, extra;
    for (const auto& name : want)
      if (!contains(name)) missing += (missing.empty() ? "'" : ", '") + name + "'";
    for (const auto& kv : entries_)
      if (!want.count(kv.first)) extra += (extra.empty() ? "'" : ", '") + kv.first + "'";
    GIMM_CHECK_AS(FormatError, missing.empty() && extra.empty(),
                  "safetensors '" << source_ << "': tensor names differ; missing: "
                                  << (missing.empty() ? "none" : missing)
                                  << "; extra: " << (extra.empty() ? "none" : extra));
  }

 private:
  /// JSON parse that also rejects duplicate keys at any depth (nlohmann would keep the last).
  static nlohmann::json parse_header(const std::vector<std::uint8_t>& bytes, std::size_t end,
                                     const std::string& where) {
    std::vector<std::set<std::string>> open;  // keys seen, per enclosing object
    const auto track = [&](int, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
      using Event = nlohmann::json::parse_event_t;
      if (event == Event::object_start) open.emplace_back();
      if (event == Event::object_end) open.pop_back();
      if (event == Event::key) {
        const auto& key = parsed.get_ref<const std::string&>();
        GIMM_CHECK_AS(FormatError, open.back().insert(key).second,
                      where << "duplicate " << (open.size() == 1 ? "tensor name" : "key") << " '"
                            << key << "' in the header");
      }
      return true;
    };
    try {
      return nlohmann::json::parse(bytes.begin() + 8, bytes.begin() + std::ptrdiff_t(end), track);
    } catch (const nlohmann::json::exception& e) {
      throw FormatError("gimm: " + where + "header is not valid JSON: " + e.what());
    }
  }

  static SafetensorsEntry parse_entry(const std::string& name, const nlohmann::json& value,
                                      std::uint64_t data_size, const std::string& where) {
    const std::string tensor = where + "tensor '" + name + "': ";
    GIMM_CHECK_AS(FormatError, value.is_object(),
                  tensor << "entry is not an object (got " << value.type_name() << ")");
    for (const char* key : {"dtype", "shape", "data_offsets"})
      GIMM_CHECK_AS(FormatError, value.contains(key), tensor << "missing \"" << key << "\"");
    SafetensorsEntry e;
    e.name = name;
    const auto& dtype = value["dtype"];
    GIMM_CHECK_AS(FormatError, dtype.is_string(),
                  tensor << "dtype is not a string: " << dtype.dump());
    e.dtype = dtype.get<std::string>();
    const std::size_t element = detail::safetensors_dtype_size(e.dtype);
    GIMM_CHECK_AS(FormatError, element > 0, tensor << "unknown dtype '" << e.dtype << "'");

    const auto& shape = value["shape"];
    GIMM_CHECK_AS(FormatError, shape.is_array(),
                  tensor << "shape is not an array: " << shape.dump());
    // Element count with overflow checks; any zero extent makes it 0, but the other extents
    // must still multiply in range: a tensor's strides are their products.
    std::uint64_t numel = 1;
    bool zero = false, overflow = false;
    for (const auto& d : shape) {
      GIMM_CHECK_AS(
          FormatError,
          d.is_number_unsigned() &&
              d.get<std::uint64_t>() <= std::uint64_t(std::numeric_limits<std::int64_t>::max()),
          tensor << "bad extent " << d.dump() << " in shape " << shape.dump()
                 << " (want a non-negative integer)");
      const std::uint64_t extent = d.get<std::uint64_t>();
      e.shape.push_back(static_cast<std::int64_t>(extent));
      zero = zero || extent == 0;
      if (extent == 0) continue;
      if (numel > std::numeric_limits<std::uint64_t>::max() / element / extent)
        overflow = true;
      else
        numel *= extent;
    }
    GIMM_CHECK_AS(FormatError, !overflow && numel <= (std::uint64_t{1} << 40),
                  tensor << "shape " << shape.dump() << " is too large");
    if (zero) numel = 0;

    const auto& offsets = value["data_offsets"];
    GIMM_CHECK_AS(
        FormatError,
        offsets.is_array() && offsets.size() == 2 && offsets[0].is_number_unsigned() &&
            offsets[1].is_number_unsigned(),
        tensor << "data_offsets must be two non-negative integers, got " << offsets.dump());
    e.begin = offsets[0].get<std::uint64_t>();
    e.end = offsets[1].get<std::uint64_t>();
    GIMM_CHECK_AS(FormatError, e.begin <= e.end,
                  tensor << "data_offsets " << offsets.dump() << " begin after end");
    GIMM_CHECK_AS(FormatError, e.end <= data_size,
                  tensor << "data_offsets " << offsets.dump() << " end beyond the " << data_size
                         << "-byte data section");
    GIMM_CHECK_AS(FormatError, e.end - e.begin == numel * element,
                  tensor << "data_offsets " << offsets.dump() << " span " << e.end - e.begin
                         << " bytes but shape " << shape.dump() << " of " << e.dtype << " needs "
                         << numel * element);
    return e;
  }

  std::string source_;
  std::vector<std::uint8_t> bytes_;  // the whole file
  std::size_t data_start_ = 0;       // 8 + header length
  std::map<std::string, SafetensorsEntry> entries_;
  std::map<std::string, std::string> metadata_;
};

/// Writes float32 tensors in the given order, the header padded with spaces to a multiple of 8
/// bytes (so the data section stays 8-byte aligned), atomically. Names must be non-empty,
/// unique and not "__metadata__".
inline void write_safetensors(const std::string& path,
                              const std::vector<std::pair<std::string, const nn::Tensor*>>& tensors,
                              const std::map<std::string, std::string>& metadata) {
  detail::require_little_endian();
  nlohmann::ordered_json header = nlohmann::ordered_json::object();
  if (!metadata.empty()) header["__metadata__"] = metadata;
  std::set<std::string> seen;
  std::uint64_t offset = 0;
  for (const auto& [name, t] : tensors) {
    GIMM_CHECK(!name.empty(), "write_safetensors '" << path << "': empty tensor name");
    GIMM_CHECK(name != "__metadata__",
               "write_safetensors '" << path << "': '__metadata__' is reserved, not a tensor name");
    GIMM_CHECK(seen.insert(name).second,
               "write_safetensors '" << path << "': duplicate tensor name '" << name << "'");
    GIMM_CHECK(t != nullptr, "write_safetensors '" << path << "': tensor '" << name << "' is null");
    // A default-constructed Tensor has shape [] (one element) but no data.
    GIMM_CHECK(t->numel() == nn::shape_numel(t->shape()),
               "write_safetensors '" << path << "': tensor '" << name << "' holds " << t->numel()
                                     << " values for shape " << nn::shape_string(t->shape()));
    const std::uint64_t size = 4 * static_cast<std::uint64_t>(t->numel());
    header[name] = {
        {"dtype", "F32"}, {"shape", t->shape()}, {"data_offsets", {offset, offset + size}}};
    offset += size;
  }
  std::string text;
  try {
    text = header.dump();
  } catch (const nlohmann::json::exception& e) {
    GIMM_FAIL("write_safetensors '" << path
                                    << "': a name or metadata string is not UTF-8: " << e.what());
  }
  text.append((8 - text.size() % 8) % 8, ' ');

  std::vector<unsigned char> out(8 + text.size() + offset);
  for (int i = 0; i < 8; ++i)
    out[std::size_t(i)] = static_cast<unsigned char>(text.size() >> (8 * i));
  std::memcpy(out.data() + 8, text.data(), text.size());
  unsigned char* data = out.data() + 8 + text.size();
  for (const auto& kv : tensors) {
    const std::size_t size = 4 * static_cast<std::size_t>(kv.second->numel());
    if (size) std::memcpy(data, kv.second->data(), size);
    data += size;
  }
  write_file_atomic(path, out.data(), out.size());
}

}  // namespace gimm::nn
