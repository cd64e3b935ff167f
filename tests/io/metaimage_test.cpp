// MetaImage: plastimatch's .mha and .mhd against nibabel's NIfTI of the same volume (which pins
// TransformMatrix's layout: its first three numbers are the direction of i); hand-written
// headers for compression, byte order, HeaderSize, aliases and types; and every refusal.
#include <zlib.h>

#include <catch2/catch.hpp>

#include "gimm/io/metaimage.hpp"
#include "gimm/io/nifti.hpp"
#include "volume_fixtures.hpp"

// Its own namespace: the tests are compiled as one file (tests/CMakeLists.txt).
namespace metaimage_test {

namespace fs = std::filesystem;
using fixtures::fixture_difference;
using fixtures::format_error;
using fixtures::tmp;
using fixtures::write_text;

namespace {

/// zlib's compress2: the zlib-wrapped deflate MetaIO writes for CompressedData = True.
std::vector<unsigned char> zlib_compress(const std::vector<unsigned char>& in) {
  uLongf size = compressBound(uLong(in.size()));
  std::vector<unsigned char> out(size);
  REQUIRE(compress2(out.data(), &size, in.data(), uLong(in.size()), 6) == Z_OK);
  out.resize(size);
  return out;
}

std::string numbers(const std::vector<double>& v) {
  std::string s;
  char b[40];
  for (double x : v) {
    std::snprintf(b, sizeof b, "%.17g", x);
    s += (s.empty() ? "" : " ") + std::string(b);
  }
  return s;
}

/// The fixture's geometry keys; `matrix` is TransformMatrix as written.
std::string geometry_keys(const std::vector<double>& matrix) {
  const auto g = fixtures::expected_geometry();
  return "TransformMatrix = " + numbers(matrix) +
         "\nOffset = " + numbers({g.origin.x(), g.origin.y(), g.origin.z()}) +
         "\nAnatomicalOrientation = LPI\nElementSpacing = 0.75 0.5 1.25\n";
}

/// TransformMatrix the ITK way: the direction of axis i, then of j, then of k.
std::vector<double> itk_matrix() {
  const Eigen::Matrix3d d = fixtures::expected_geometry().direction;
  std::vector<double> m;
  for (int axis = 0; axis < 3; ++axis)
    for (int r = 0; r < 3; ++r) m.push_back(d(r, axis));
  return m;
}

/// A header for the fixture's grid, its last key ElementDataFile = `data_file`.
std::string header(const std::string& data_file, const std::string& extra = "",
                   const std::vector<double>& matrix = itk_matrix()) {
  return "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
         "CompressedData = False\n" +
         geometry_keys(matrix) + extra + "DimSize = 5 4 3\nElementType = MET_SHORT\n" +
         "ElementDataFile = " + data_file + "\n";
}

std::string raw_path() {
  return (fixtures::dir() / "ct_mhd.raw").string();
}

gimm::Volume<std::int16_t> read_header(const std::string& name, const std::string& text,
                                       const std::vector<unsigned char>& data = {}) {
  const auto p = tmp(name);
  write_text(p, text, data);
  return gimm::read_metaimage<std::int16_t>(p);
}

template <class T = float>
std::string mha_error(const std::string& name, const std::string& text,
                      const std::vector<unsigned char>& data = {}) {
  const auto p = tmp(name);
  write_text(p, text, data);
  return format_error([&] { (void)gimm::read_metaimage<T>(p); }, p);
}

}  // namespace

TEST_CASE("MetaImage files written by plastimatch read as nibabel's NIfTI of the same volume",
          "[io][metaimage]") {
  const auto nifti = gimm::read_nifti<std::int16_t>(fixtures::dir() / "source.nii");
  for (const char* name : {"ct.mha", "ct_mhd.mhd"}) {
    INFO(name);
    const auto p = fixtures::dir() / name;
    const auto v = gimm::read_metaimage<std::int16_t>(p);
    CHECK(fixture_difference(v) == "");
    CHECK(v.storage() == nifti.storage());
    CHECK((v.origin() - nifti.origin()).cwiseAbs().maxCoeff() < 1e-6);
    CHECK((v.spacing() - nifti.spacing()).cwiseAbs().maxCoeff() < 1e-6);
    CHECK((v.direction() - nifti.direction()).cwiseAbs().maxCoeff() < 1e-6);
    CHECK(gimm::read_metaimage_header(p).anatomical_orientation == "LPI");
    CHECK(fixture_difference(gimm::read_metaimage<double>(p)) == "");
  }
}

TEST_CASE("MetaImage TransformMatrix lists axis directions; transposed or flipped is seen",
          "[io][metaimage]") {
  CHECK(fixture_difference(read_header("itk.mhd", header(raw_path()))) == "");
  // The same numbers read as rows of the direction matrix would give its transpose.
  auto transposed = itk_matrix();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      transposed[std::size_t(3 * r + c)] = itk_matrix()[std::size_t(3 * c + r)];
  CHECK(fixture_difference(read_header("transposed.mhd", header(raw_path(), "", transposed))) !=
        "");
  auto flipped = itk_matrix();
  for (int r = 0; r < 3; ++r) flipped[std::size_t(r)] *= -1;  // axis i reversed
  CHECK(fixture_difference(read_header("flipped.mhd", header(raw_path(), "", flipped))) != "");
  // Aliases: Position / Origin for Offset, Rotation / Orientation for TransformMatrix.
  for (const auto& [offset, matrix] :
       {std::pair<std::string, std::string>{"Position", "Rotation"}, {"Origin", "Orientation"}}) {
    INFO(offset << " " << matrix);
    std::string text = fixtures::replaced(header(raw_path()), "Offset =", offset + " =");
    text = fixtures::replaced(text, "TransformMatrix =", matrix + " =");
    CHECK(fixture_difference(read_header("alias.mhd", text)) == "");
  }
  // Without geometry keys: spacing 1, origin 0, identity (MetaIO's defaults).
  const auto v = read_header("plain.mhd",
                             "NDims = 3\nDimSize = 5 4 3\nBinaryData = True\n"
                             "ElementType = MET_SHORT\nElementDataFile = " +
                                 raw_path() + "\n");
  CHECK(v.spacing() == Eigen::Vector3d(1, 1, 1));
  CHECK(v.origin() == Eigen::Vector3d::Zero());
  CHECK(v.direction() == Eigen::Matrix3d::Identity());
}

TEST_CASE("MetaImage compressed (zlib), big endian, HeaderSize", "[io][metaimage]") {
  const auto raw = fixtures::raw_int16();
  const auto packed = zlib_compress(raw);
  const std::string compressed = fixtures::replaced(
      header("LOCAL"), "CompressedData = False",
      "CompressedData = True\nCompressedDataSize = " + std::to_string(packed.size()));
  CHECK(fixture_difference(read_header("zlib.mha", compressed, packed)) == "");
  // Without CompressedDataSize the stream runs to the end of the file.
  CHECK(fixture_difference(read_header(
            "zlib_nosize.mha",
            fixtures::replaced(header("LOCAL"), "CompressedData = False", "CompressedData = True"),
            packed)) == "");
  // Detached, relative to the header, and gzip-wrapped (which MetaIO's reader accepts too).
  fixtures::write_bytes(tmp("zlib.zraw"), packed);
  CHECK(fixture_difference(read_header(
            "zlib.mhd", fixtures::replaced(header("zlib.zraw"), "CompressedData = False",
                                           "CompressedData = True"))) == "");
  fixtures::write_bytes(tmp("gzip.zraw"), gimm::gzip_compress(raw.data(), raw.size()));
  CHECK(fixture_difference(read_header(
            "gzip.mhd", fixtures::replaced(header("gzip.zraw"), "CompressedData = False",
                                           "CompressedData = True"))) == "");

  // Big endian, under either key.
  const auto be = tmp("be.raw");
  fixtures::write_bytes(be, fixtures::swapped16(raw));
  for (const char* key : {"BinaryDataByteOrderMSB", "ElementByteOrderMSB"}) {
    INFO(key);
    const std::string text = fixtures::replaced(
        header(be.string()), "BinaryDataByteOrderMSB = False", std::string(key) + " = True");
    CHECK(fixture_difference(read_header("be.mhd", text)) == "");
  }
  CHECK(fixture_difference(read_header("be_as_little.mhd", header(be.string()))) != "");

  // HeaderSize: bytes skipped at the start of the data file; -1: the data is its last bytes.
  std::vector<unsigned char> with_header(37, 0xab);
  with_header.insert(with_header.end(), raw.begin(), raw.end());
  const auto skipped = tmp("skipped.raw");
  fixtures::write_bytes(skipped, with_header);
  CHECK(fixture_difference(read_header("hs.mhd", header(skipped.string(), "HeaderSize = 37\n"))) ==
        "");
  CHECK(fixture_difference(read_header("hs.mhd", header(skipped.string(), "HeaderSize = -1\n"))) ==
        "");
  CHECK(fixture_difference(
            read_header("hs_local.mha", header("LOCAL", "HeaderSize = -1\n"), raw)) == "");
  auto packed_with_header = std::vector<unsigned char>(37, 0xab);
  packed_with_header.insert(packed_with_header.end(), packed.begin(), packed.end());
  fixtures::write_bytes(tmp("hs.zraw"), packed_with_header);
  CHECK(fixture_difference(read_header(
            "hs_z.mhd", fixtures::replaced(header("hs.zraw", "HeaderSize = 37\n"),
                                           "CompressedData = False", "CompressedData = True"))) ==
        "");
  // CRLF line endings.
  std::string crlf;
  for (char c : header("LOCAL")) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  CHECK(fixture_difference(read_header("crlf.mha", crlf, raw)) == "");
}

TEST_CASE("MetaImage reads every element type", "[io][metaimage]") {
  using Value = std::function<double(std::size_t)>;
  const auto check = [](const char* type, auto stored, const Value& value) {
    using Stored = decltype(stored);
    for (const bool big : {false, true}) {
      INFO(type << (big ? " big" : " little"));
      std::string text = fixtures::replaced(header("LOCAL"), "MET_SHORT", type);
      if (big) text = fixtures::replaced(text, "MSB = False", "MSB = True");
      const auto p = tmp("typed.mha");
      write_text(p, text, fixtures::stored_bytes<Stored>(big, value));
      const auto v = gimm::read_metaimage<double>(p);
      REQUIRE(v.size() == 60);
      for (std::size_t n = 0; n < 60; ++n) REQUIRE(v.data()[n] == value(n));
    }
  };
  const Value fixture = fixtures::expected_value;
  check("MET_CHAR", std::int8_t{}, [](std::size_t n) { return double(n) - 30; });
  check("MET_UCHAR", std::uint8_t{}, [](std::size_t n) { return 4.0 * double(n); });
  check("MET_SHORT", std::int16_t{}, fixture);
  check("MET_USHORT", std::uint16_t{}, [&](std::size_t n) { return fixture(n) + 1000; });
  check("MET_INT", std::int32_t{}, [&](std::size_t n) { return fixture(n) * 1000; });
  check("MET_LONG", std::int32_t{}, [&](std::size_t n) { return fixture(n) * 1000; });
  check("MET_UINT", std::uint32_t{}, [&](std::size_t n) { return (fixture(n) + 1000) * 1000; });
  check("MET_ULONG", std::uint32_t{}, [&](std::size_t n) { return (fixture(n) + 1000) * 1000; });
  check("MET_FLOAT", float{}, [&](std::size_t n) { return fixture(n) + 0.5; });
  check("MET_DOUBLE", double{}, [&](std::size_t n) { return fixture(n) + 0.25; });
}

TEST_CASE("MetaImage refuses what it does not read, naming the file, the key and the value",
          "[io][metaimage]") {
  const std::string base = header(raw_path());
  const auto refused = [&](const std::string& from, const std::string& to,
                           const std::vector<std::string>& fragments) {
    const std::string msg = mha_error("refused.mhd", fixtures::replaced(base, from, to));
    for (const auto& f : fragments) CHECK_THAT(msg, Catch::Contains(f));
  };
  refused("NDims = 3", "NDims = 2", {"NDims = 2"});
  refused("NDims = 3\n", "", {"missing NDims"});
  refused("DimSize = 5 4 3\n", "", {"missing DimSize"});
  refused("DimSize = 5 4 3", "DimSize = 5 4", {"DimSize", "3 values"});
  refused("MET_SHORT", "MET_LONG_LONG", {"ElementType", "MET_LONG_LONG"});
  refused("MET_SHORT", "MET_SHORT_ARRAY", {"ElementType", "MET_SHORT_ARRAY"});
  refused("ObjectType = Image", "ObjectType = Mesh", {"ObjectType", "Mesh"});
  refused("BinaryData = True", "BinaryData = False", {"BinaryData", "text voxels"});
  refused("BinaryData = True\n", "", {"missing BinaryData"});
  refused("BinaryData = True", "BinaryData = Maybe", {"BinaryData", "Maybe"});
  refused("DimSize = 5 4 3", "DimSize = 5 4 3\nElementNumberOfChannels = 3",
          {"ElementNumberOfChannels", "3"});
  refused("DimSize = 5 4 3", "DimSize = 5 4 3\nElementToIntensityFunctionSlope = 2",
          {"ElementToIntensityFunctionSlope", "2"});
  refused("ElementDataFile = " + raw_path(), "ElementDataFile = LIST", {"ElementDataFile", "LIST"});
  refused("ElementDataFile = " + raw_path(), "ElementDataFile = slice%03d.raw 1 3 1",
          {"ElementDataFile", "slice%03d.raw"});
  refused("ElementDataFile = " + raw_path() + "\n", "", {"missing ElementDataFile"});
  refused("DimSize = 5 4 3", "DimSize = 5 4 3\nHeaderSize = -2", {"HeaderSize", "-2"});
  refused("Offset =", "Offset = 1 2 3\nPosition =", {"'Position' repeats 'Offset'"});
  refused("ElementSpacing = 0.75 0.5 1.25", "ElementSpacing = 0.75 0 1.25", {"spacing 1"});
  refused("ObjectType = Image", "this is not a header", {"not 'Key = Value'"});
  // A matrix that is not a rotation.
  auto sheared = itk_matrix();
  sheared[3] += 0.3;
  const std::string msg = mha_error("sheared.mhd", header(raw_path(), "", sheared));
  CHECK_THAT(msg, Catch::Contains("not orthonormal"));
  CHECK_THAT(mha_error("local_hs.mha", header("LOCAL", "HeaderSize = 4\n"), fixtures::raw_int16()),
             Catch::Contains("HeaderSize = 4 with ElementDataFile = LOCAL"));
}

TEST_CASE("MetaImage data that is short, long, or claimed absurdly large is an error",
          "[io][metaimage]") {
  const auto raw = fixtures::raw_int16();
  const auto short_raw = tmp("short.raw");
  fixtures::write_bytes(short_raw, std::vector<unsigned char>(raw.begin(), raw.begin() + 100));
  std::string msg = mha_error("short.mhd", header(short_raw.string()));
  CHECK_THAT(msg, Catch::Contains("truncated") && Catch::Contains("need 120 bytes") &&
                      Catch::Contains("found 100") && Catch::Contains(short_raw.string()));
  msg = mha_error("cut.mha", header("LOCAL"),
                  std::vector<unsigned char>(raw.begin(), raw.begin() + 60));
  CHECK_THAT(msg, Catch::Contains("truncated") && Catch::Contains("found 60"));
  auto longer = raw;
  longer.push_back(0);
  CHECK_THAT(mha_error("long.mha", header("LOCAL"), longer),
             Catch::Contains("1 bytes beyond the voxel data"));

  // Compressed: cut short, CompressedDataSize beyond the file, bytes after it.
  const auto packed = zlib_compress(raw);
  const std::string z = fixtures::replaced(
      header("LOCAL"), "CompressedData = False",
      "CompressedData = True\nCompressedDataSize = " + std::to_string(packed.size()));
  msg = mha_error("zcut.mha", z, std::vector<unsigned char>(packed.begin(), packed.end() - 1));
  CHECK_THAT(msg, Catch::Contains("truncated") && Catch::Contains("CompressedDataSize"));
  auto packed_more = packed;
  packed_more.push_back(7);
  CHECK_THAT(mha_error("zlong.mha", z, packed_more),
             Catch::Contains("1 bytes") && Catch::Contains("beyond the"));
  const std::string nosize =
      fixtures::replaced(header("LOCAL"), "CompressedData = False", "CompressedData = True");
  msg =
      mha_error("zcut2.mha", nosize, std::vector<unsigned char>(packed.begin(), packed.end() - 4));
  CHECK_THAT(msg, Catch::Contains("truncated") && Catch::Contains("need 120 bytes"));
  msg = mha_error("zgarbage.mha", nosize, std::vector<unsigned char>(40, 0x55));
  CHECK_THAT(msg, Catch::Contains("corrupt"));

  // 2^40 voxels claimed with 120 bytes of data: refused before allocating.
  const std::string huge =
      fixtures::replaced(header(raw_path()), "DimSize = 5 4 3", "DimSize = 65536 65536 256");
  msg = mha_error("huge.mhd", huge);
  CHECK_THAT(msg, Catch::Contains("need 2199023255552 bytes") && Catch::Contains("found 120"));
  msg = mha_error("huge_z.mha",
                  fixtures::replaced(z, "DimSize = 5 4 3", "DimSize = 65536 65536 256"), packed);
  CHECK_THAT(msg, Catch::Contains("2199023255552") && Catch::Contains("inflate"));
  msg = mha_error("wide.mhd", fixtures::replaced(header(raw_path()), "DimSize = 5 4 3",
                                                 "DimSize = 1099511627776 1 1"));
  CHECK_THAT(msg, Catch::Contains("DimSize 0 is 1099511627776"));
}

TEST_CASE("MetaImage into an integer type refuses values that are not integers in range",
          "[io][metaimage]") {
  auto values = fixtures::stored_bytes<float>(false);
  const float half = -0.25f;
  std::memcpy(values.data() + 8, &half, 4);  // voxel 2
  const std::string text = fixtures::replaced(header("LOCAL"), "MET_SHORT", "MET_FLOAT");
  CHECK_THAT(
      mha_error<std::int16_t>("float.mha", text, values),
      Catch::Contains("voxel 2") && Catch::Contains("-0.25") && Catch::Contains("does not fit"));
  CHECK(fixture_difference(read_header("float.mha", text, fixtures::stored_bytes<float>(false))) ==
        "");
  CHECK_THAT(mha_error<std::uint16_t>("float.mha", text, fixtures::stored_bytes<float>(false)),
             Catch::Contains("voxel 0"));
}

}  // namespace metaimage_test
