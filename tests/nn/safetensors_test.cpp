// safetensors: round trip, dtype conversion, a file written by tools/train/safetensors_io.py, and
// every malformed-header error naming the source and the bad tensor/value.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include "gimm/nn/safetensors.hpp"

namespace fs = std::filesystem;
using gimm::nn::SafetensorsFile;
using Bytes = std::vector<std::uint8_t>;

namespace {

const std::string kSource = "case.safetensors";

fs::path tmp_path(const std::string& name) {
  fs::create_directories(GIMM_TEST_TMP);
  return fs::path(GIMM_TEST_TMP) / name;
}

void write_bytes(const fs::path& p, const Bytes& bytes) {
  std::ofstream(p, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
}

/// Length field (the header's size unless `declared` is given), header text, then `data`.
Bytes file_bytes(const std::string& header, const Bytes& data,
                 std::uint64_t declared = std::numeric_limits<std::uint64_t>::max()) {
  if (declared == std::numeric_limits<std::uint64_t>::max()) declared = header.size();
  Bytes out;
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<std::uint8_t>(declared >> (8 * i)));
  out.insert(out.end(), header.begin(), header.end());
  out.insert(out.end(), data.begin(), data.end());
  return out;
}

Bytes zeros(std::size_t n) {
  return Bytes(n, 0);
}

template <class T>
Bytes raw(const std::vector<T>& values) {
  Bytes out(values.size() * sizeof(T));
  if (!out.empty()) std::memcpy(out.data(), values.data(), out.size());
  return out;
}

SafetensorsFile parse(const Bytes& bytes) {
  return SafetensorsFile::parse(bytes, kSource);
}

/// Parsing must throw a FormatError whose message names the source and every fragment.
void require_format_error(const Bytes& bytes, const std::vector<std::string>& fragments) {
  CHECK_THROWS_AS(parse(bytes), gimm::FormatError);
  CHECK_THROWS_WITH(parse(bytes), Catch::Contains(kSource));
  for (const auto& fragment : fragments) CHECK_THROWS_WITH(parse(bytes), Catch::Contains(fragment));
}

void require_header_error(const std::string& header, std::size_t data_size,
                          const std::vector<std::string>& fragments) {
  INFO(header);
  require_format_error(file_bytes(header, zeros(data_size)), fragments);
}

/// One F32 tensor "w" whose entry is `entry`, with `data_size` data bytes.
void require_entry_error(const std::string& entry, std::size_t data_size,
                         const std::vector<std::string>& fragments) {
  std::vector<std::string> with_name = fragments;
  with_name.push_back("'w'");
  require_header_error("{\"w\":" + entry + "}", data_size, with_name);
}

gimm::nn::Tensor ramp(gimm::nn::Shape shape, float scale) {
  gimm::nn::Tensor t(std::move(shape));
  for (std::int64_t i = 0; i < t.numel(); ++i) t[i] = scale * float(i) - 1.5f;
  return t;
}

}  // namespace

TEST_CASE("safetensors round trip keeps values, shapes, metadata and order", "[io][safetensors]") {
  const auto conv = ramp({4, 3, 2, 2}, 0.25f), bias = ramp({4}, -3.0f), scalar = ramp({}, 2.0f),
             empty = ramp({0, 3}, 1.0f);
  const std::map<std::string, std::string> metadata = {{"format", "pt"}, {"epoch", "12"}};
  const auto p = tmp_path("round.safetensors");
  gimm::nn::write_safetensors(
      p.string(), {{"z.conv", &conv}, {"a.bias", &bias}, {"m.scalar", &scalar}, {"e", &empty}},
      metadata);

  const auto file = SafetensorsFile::load(p.string());
  CHECK(file.metadata() == metadata);
  CHECK(file.names() == std::vector<std::string>{"a.bias", "e", "m.scalar", "z.conv"});
  CHECK(file.contains("z.conv"));
  CHECK_FALSE(file.contains("conv"));
  for (const auto& [name, t] : std::vector<std::pair<std::string, const gimm::nn::Tensor*>>{
           {"z.conv", &conv}, {"a.bias", &bias}, {"m.scalar", &scalar}, {"e", &empty}}) {
    const auto back = file.tensor(name, t->shape());
    CHECK(back.shape() == t->shape());
    CHECK(back.values() == t->values());
    CHECK(file.entry(name).dtype == "F32");
  }
  // Data in the given order; the header is space-padded so the data starts 8-byte aligned.
  CHECK(file.entry("z.conv").begin == 0);
  CHECK(file.entry("a.bias").begin == 4 * 48);
  CHECK(file.entry("m.scalar").begin == 4 * 52);
  CHECK(file.entry("e").begin == file.entry("e").end);
  const auto bytes = gimm::read_file_bytes(p);
  std::uint64_t header_size = 0;
  std::memcpy(&header_size, bytes.data(), 8);
  CHECK(header_size % 8 == 0);
  CHECK(bytes.size() == 8 + header_size + 4 * 53);
  CHECK(bytes[8] == '{');
  CHECK(bytes[8 + header_size - 1] != '\0');

  file.expect_names({"e", "m.scalar", "z.conv", "a.bias"});
  CHECK_THROWS_WITH(file.expect_names({"a.bias", "e", "m.scalar", "head.w", "head.b"}),
                    Catch::Contains(p.string()) && Catch::Contains("missing: 'head.b', 'head.w'") &&
                        Catch::Contains("extra: 'z.conv'"));
  CHECK_THROWS_WITH(file.tensor("z.conv", {4, 3, 4}), Catch::Contains("'z.conv'") &&
                                                          Catch::Contains("[4, 3, 2, 2]") &&
                                                          Catch::Contains("expected [4, 3, 4]"));
  CHECK_THROWS_WITH(file.tensor("nope"), Catch::Contains("'nope'") && Catch::Contains(p.string()));

  // No metadata: no __metadata__ key, an empty map back.
  gimm::nn::write_safetensors(p.string(), {{"b", &bias}}, {});
  CHECK(SafetensorsFile::load(p.string()).metadata().empty());
}

TEST_CASE("safetensors writer rejects bad names", "[io][safetensors]") {
  const auto t = ramp({2}, 1.0f);
  const auto p = tmp_path("bad_names.safetensors").string();
  CHECK_THROWS_WITH(gimm::nn::write_safetensors(p, {{"a", &t}, {"a", &t}}, {}),
                    Catch::Contains("duplicate") && Catch::Contains("'a'"));
  CHECK_THROWS_WITH(gimm::nn::write_safetensors(p, {{"", &t}}, {}), Catch::Contains("empty"));
  CHECK_THROWS_WITH(gimm::nn::write_safetensors(p, {{"__metadata__", &t}}, {}),
                    Catch::Contains("reserved"));
  CHECK_THROWS_WITH(gimm::nn::write_safetensors(p, {{"n", nullptr}}, {}), Catch::Contains("'n'"));
  const gimm::nn::Tensor none;  // shape [] but no data
  CHECK_THROWS_WITH(gimm::nn::write_safetensors(p, {{"none", &none}}, {}),
                    Catch::Contains("'none'"));
  CHECK_FALSE(fs::exists(p));
}

TEST_CASE("safetensors F16, BF16 and F64 convert to float32", "[io][safetensors]") {
  const std::vector<std::uint16_t> f16 = {0x3C00, 0xC100, 0x7BFF, 0x0001,
                                          0x03FF, 0x8000, 0x7C00, 0x7E00};
  const std::vector<std::uint16_t> bf16 = {0x3F80, 0xC020, 0x477F, 0x0001, 0x7F7F, 0xFF80};
  const std::vector<double> f64 = {1.0, -2.5, 65504.0, 0.1, 1e-40, -0.0};
  Bytes data = raw(f16), more = raw(bf16), last = raw(f64);
  data.insert(data.end(), more.begin(), more.end());
  data.insert(data.end(), last.begin(), last.end());
  const std::string header = R"({"h":{"dtype":"F16","shape":[2,4],"data_offsets":[0,16]},)"
                             R"("b":{"dtype":"BF16","shape":[6],"data_offsets":[16,28]},)"
                             R"("d":{"dtype":"F64","shape":[3,2],"data_offsets":[28,76]}})";
  const auto file = parse(file_bytes(header, data));

  const auto h = file.tensor("h", {2, 4});
  CHECK(h[0] == 1.0f);
  CHECK(h[1] == -2.5f);
  CHECK(h[2] == 65504.0f);
  CHECK(h[3] == std::ldexp(1.0f, -24));  // smallest half subnormal
  CHECK(h[4] == std::ldexp(1023.0f, -24));
  CHECK((h[5] == 0.0f && std::signbit(h[5])));
  CHECK(h[6] == std::numeric_limits<float>::infinity());
  CHECK(std::isnan(h[7]));

  const auto b = file.tensor("b");
  CHECK(b[0] == 1.0f);
  CHECK(b[1] == -2.5f);
  CHECK(b[2] == 65280.0f);
  CHECK(b[3] == std::ldexp(1.0f, -133));  // smallest bfloat16 subnormal
  CHECK(b[4] == 0x1.FEp127f);
  CHECK(b[5] == -std::numeric_limits<float>::infinity());

  const auto d = file.tensor("d");
  CHECK(d.shape() == gimm::nn::Shape{3, 2});
  CHECK(d[0] == 1.0f);
  CHECK(d[1] == -2.5f);
  CHECK(d[2] == 65504.0f);
  CHECK(d[3] == 0.1f);  // rounded to nearest
  CHECK(d[4] == static_cast<float>(1e-40));
  CHECK(d[4] > 0.0f);
  CHECK((d[5] == 0.0f && std::signbit(d[5])));

  // A finite F64 beyond float range is an error, not inf.
  const auto big = parse(file_bytes(R"({"x":{"dtype":"F64","shape":[1],"data_offsets":[0,8]}})",
                                    raw(std::vector<double>{-1e300})));
  CHECK_THROWS_WITH(big.tensor("x"), Catch::Contains("'x'") && Catch::Contains("-1e+300"));
}

TEST_CASE("safetensors integer dtypes parse but do not convert", "[io][safetensors]") {
  const auto file =
      parse(file_bytes(R"({"steps":{"dtype":"I64","shape":[],"data_offsets":[0,8]}})", zeros(8)));
  CHECK(file.entry("steps").dtype == "I64");
  CHECK(file.entry("steps").shape.empty());
  CHECK_THROWS_AS(file.tensor("steps"), gimm::Error);
  CHECK_THROWS_WITH(file.tensor("steps"), Catch::Contains("'steps'") && Catch::Contains("I64") &&
                                              Catch::Contains(kSource));
}

TEST_CASE("safetensors file written by tools/train/safetensors_io.py", "[io][safetensors]") {
  // save_file(p, {"b": np.array([[0.5]]), "a": torch.tensor([1.0, -2.5])}, {"format": "pt"})
  const std::string hex =
      "90000000000000007b225f5f6d657461646174615f5f223a7b22666f726d6174223a227074227d2c2261223a"
      "7b226474797065223a22463332222c227368617065223a5b325d2c22646174615f6f666673657473223a5b30"
      "2c385d7d2c2262223a7b226474797065223a22463332222c227368617065223a5b312c315d2c22646174615f"
      "6f666673657473223a5b382c31325d7d7d2020200000803f000020c00000003f";
  Bytes python;
  for (std::size_t i = 0; i < hex.size(); i += 2)
    python.push_back(static_cast<std::uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  const auto file = parse(python);
  CHECK(file.metadata() == std::map<std::string, std::string>{{"format", "pt"}});
  CHECK(file.tensor("a", {2}).values() == std::vector<float>{1.0f, -2.5f});
  CHECK(file.tensor("b", {1, 1}).values() == std::vector<float>{0.5f});

  // Same tensors in sorted order: gimm writes the very same bytes.
  const auto a = file.tensor("a"), b = file.tensor("b");
  const auto p = tmp_path("python_same.safetensors");
  gimm::nn::write_safetensors(p.string(), {{"a", &a}, {"b", &b}}, {{"format", "pt"}});
  CHECK(gimm::read_file_bytes(p) == python);
}

TEST_CASE("safetensors missing file is an IoError naming the path", "[io][safetensors]") {
  const auto p = tmp_path("does_not_exist.safetensors").string();
  CHECK_THROWS_AS(SafetensorsFile::load(p), gimm::IoError);
  CHECK_THROWS_WITH(SafetensorsFile::load(p), Catch::Contains(p));
}

TEST_CASE("safetensors length field errors", "[io][safetensors]") {
  for (std::size_t n = 0; n < 8; ++n)
    require_format_error(zeros(n), {std::to_string(n) + " bytes"});
  require_format_error(file_bytes("", zeros(8), 0), {"header length is 0"});
  require_format_error(file_bytes("{}", {}, 3), {"header length 3", "2 bytes"});
  require_format_error(file_bytes("{}", {}, 100'000'001), {"100000001", "absurd"});
  require_format_error(file_bytes("{}", {}, std::numeric_limits<std::uint64_t>::max() - 1),
                       {"absurd"});
}

TEST_CASE("safetensors header JSON errors", "[io][safetensors]") {
  require_header_error(R"({"w":{"dtype":"F32",)", 0, {"not valid JSON"});
  require_header_error("{} trailing", 0, {"not valid JSON"});
  require_header_error("{\"w\xff\":1}", 0, {"not valid JSON"});  // not UTF-8
  require_header_error("[1,2]", 0, {"not a JSON object", "array"});
  require_header_error("\"text\"", 0, {"not a JSON object", "string"});
  require_header_error(R"({"__metadata__":["a"]})", 0, {"__metadata__", "array"});
  require_header_error(R"({"__metadata__":{"epoch":12}})", 0, {"__metadata__", "'epoch'", "12"});
  const std::string w = R"({"dtype":"F32","shape":[1],"data_offsets":[0,4]})";
  require_header_error("{\"w\":" + w + ",\"w\":" + w + "}", 4, {"duplicate tensor name 'w'"});
  require_header_error(R"({"__metadata__":{"k":"1","k":"2"}})", 0, {"duplicate key 'k'"});
  require_header_error(R"({"w":{"dtype":"F32","dtype":"F16","shape":[1],"data_offsets":[0,4]}})", 4,
                       {"duplicate key 'dtype'"});
  // An empty header object with no data is a valid (empty) file.
  CHECK(parse(file_bytes("{}      ", {})).names().empty());
}

TEST_CASE("safetensors entry errors name the tensor and the value", "[io][safetensors]") {
  require_entry_error("[0,4]", 4, {"not an object", "array"});
  require_entry_error(R"({"shape":[1],"data_offsets":[0,4]})", 4, {"missing \"dtype\""});
  require_entry_error(R"({"dtype":"F32","data_offsets":[0,4]})", 4, {"missing \"shape\""});
  require_entry_error(R"({"dtype":"F32","shape":[1]})", 4, {"missing \"data_offsets\""});
  require_entry_error(R"({"dtype":32,"shape":[1],"data_offsets":[0,4]})", 4, {"dtype", "32"});
  require_entry_error(R"({"dtype":"F12","shape":[1],"data_offsets":[0,4]})", 4,
                      {"unknown dtype 'F12'"});
  require_entry_error(R"({"dtype":"F32","shape":4,"data_offsets":[0,4]})", 4, {"shape", "4"});
  require_entry_error(R"({"dtype":"F32","shape":[-2],"data_offsets":[0,4]})", 4,
                      {"bad extent -2", "[-2]"});
  require_entry_error(R"({"dtype":"F32","shape":[2.5],"data_offsets":[0,4]})", 4,
                      {"bad extent 2.5"});
  require_entry_error(R"({"dtype":"F32","shape":["1"],"data_offsets":[0,4]})", 4,
                      {"bad extent \"1\""});
  require_entry_error(R"({"dtype":"F32","shape":[9223372036854775808],"data_offsets":[0,4]})", 4,
                      {"bad extent 9223372036854775808"});
  require_entry_error(R"({"dtype":"F32","shape":[4294967296,4294967296,4],"data_offsets":[0,4]})",
                      4, {"too large"});
  // No element, but strides that overflow int64 (2^62 * 2^62): refused at parse time, before a
  // Tensor computes them (UBSan: signed overflow in Tensor::update_strides).
  require_entry_error(
      R"({"dtype":"F32","shape":[0,4611686018427387904,4611686018427387904],"data_offsets":[0,0]})",
      0, {"too large", "[0,4611686018427387904,4611686018427387904]"});
  require_entry_error(R"({"dtype":"F32","shape":[0,2199023255553],"data_offsets":[0,0]})", 0,
                      {"too large"});
  for (const std::string offsets : {"[0]", "[0,4,8]", "[0,\"4\"]", "[-1,4]", "[0,4.0]", "{}"})
    require_entry_error(R"({"dtype":"F32","shape":[1],"data_offsets":)" + offsets + "}", 4,
                        {"two non-negative integers", offsets});
  require_entry_error(R"({"dtype":"F32","shape":[1],"data_offsets":[8,4]})", 8,
                      {"[8,4]", "begin after end"});
  require_entry_error(R"({"dtype":"F32","shape":[4],"data_offsets":[0,16]})", 8,
                      {"[0,16]", "beyond the 8-byte data section"});
  require_entry_error(R"({"dtype":"F32","shape":[3],"data_offsets":[0,8]})", 8,
                      {"[0,8]", "span 8 bytes", "[3]", "needs 12"});
  require_entry_error(R"({"dtype":"F16","shape":[2,2],"data_offsets":[0,16]})", 16,
                      {"F16", "needs 8"});
}

TEST_CASE("safetensors tensors must tile the data section exactly", "[io][safetensors]") {
  require_header_error(R"({"a":{"dtype":"F32","shape":[2],"data_offsets":[0,8]},)"
                       R"("b":{"dtype":"F32","shape":[2],"data_offsets":[4,12]}})",
                       12, {"'a' [0, 8]", "'b' [4, 12]", "overlap"});
  require_header_error(R"({"a":{"dtype":"F32","shape":[2],"data_offsets":[0,8]},)"
                       R"("b":{"dtype":"F32","shape":[2],"data_offsets":[0,8]}})",
                       8, {"'a'", "'b'", "overlap"});
  require_header_error(R"({"a":{"dtype":"F32","shape":[1],"data_offsets":[0,4]},)"
                       R"("b":{"dtype":"F32","shape":[1],"data_offsets":[8,12]}})",
                       12, {"[4, 8)", "not covered"});
  require_header_error(R"({"a":{"dtype":"F32","shape":[1],"data_offsets":[4,8]}})", 8,
                       {"[0, 4)", "not covered"});
  require_header_error(R"({"a":{"dtype":"F32","shape":[1],"data_offsets":[0,4]}})", 8,
                       {"[4, 8)", "not covered"});
  require_header_error("{}", 4, {"[0, 4)", "not covered"});
  // Empty tensors take no bytes and may sit at any boundary.
  const auto file = parse(file_bytes(R"({"a":{"dtype":"F32","shape":[1],"data_offsets":[0,4]},)"
                                     R"("e":{"dtype":"F32","shape":[0,7],"data_offsets":[4,4]}})",
                                     zeros(4)));
  CHECK(file.tensor("e", {0, 7}).empty());
}

TEST_CASE("safetensors truncated or corrupted files throw, never crash", "[io][safetensors]") {
  const auto w = ramp({3, 5}, 0.5f), b = ramp({5}, 1.0f);
  const auto p = tmp_path("cut.safetensors");
  gimm::nn::write_safetensors(p.string(), {{"w", &w}, {"b", &b}}, {{"note", "x"}});
  const auto bytes = gimm::read_file_bytes(p);
  for (std::size_t cut = 0; cut < bytes.size(); ++cut) {
    INFO("cut at " << cut << " of " << bytes.size());
    const Bytes part(bytes.begin(), bytes.begin() + std::ptrdiff_t(cut));
    CHECK_THROWS_AS(parse(part), gimm::FormatError);
  }
  write_bytes(p, Bytes(bytes.begin(), bytes.begin() + 20));
  CHECK_THROWS_WITH(SafetensorsFile::load(p.string()), Catch::Contains(p.string()));

  // Every byte of the length field and header replaced by a few values: parse either fails
  // cleanly or yields a file whose tensors all read within bounds.
  std::uint64_t header_size = 0;
  std::memcpy(&header_size, bytes.data(), 8);
  int parsed = 0;
  for (std::size_t i = 0; i < 8 + header_size; ++i)
    for (const std::uint8_t v : {0x00, 0x01, 0x20, 0x22, 0x2c, 0x30, 0x39, 0x5b, 0x7d, 0xff}) {
      Bytes bad = bytes;
      bad[i] = v;
      try {
        const auto file = parse(bad);
        ++parsed;
        for (const auto& name : file.names()) (void)file.tensor(name);
      } catch (const gimm::Error&) {
      }
    }
  CHECK(parsed > 0);  // e.g. digits swapped inside a metadata string
}
