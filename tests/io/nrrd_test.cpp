// NRRD: plastimatch's files (attached gzip, detached raw) against nibabel's NIfTI of the same
// volume; hand-written headers for the spaces, byte orders, encodings, skips, type spellings,
// 4D stub axes; and every refusal naming the file and the field.
#include <catch2/catch.hpp>

#include "gimm/io/gzip.hpp"
#include "gimm/io/nifti.hpp"
#include "gimm/io/nrrd.hpp"
#include "volume_fixtures.hpp"

// Its own namespace: the tests are compiled as one file (tests/CMakeLists.txt).
namespace nrrd_test {

namespace fs = std::filesystem;
using fixtures::fixture_difference;
using fixtures::format_error;
using fixtures::tmp;
using fixtures::write_text;

namespace {

/// The fixture's space fields in `space`, whose axes are LPS's times `flip`.
std::string space_fields(const std::string& space, const Eigen::Vector3d& flip) {
  const auto g = fixtures::expected_geometry();
  std::string s = "space: " + space + "\nspace directions:";
  for (int a = 0; a < 3; ++a)
    s += " " + fixtures::vec(flip.asDiagonal() * g.direction.col(a) * g.spacing[a]);
  return s + "\nspace origin: " + fixtures::vec(flip.asDiagonal() * g.origin) + "\n";
}

/// A header for the fixture voxels (int16 little-endian raw by default) in `data_file`.
std::string header(const std::string& data_file, const std::string& extra = "",
                   const std::string& space = space_fields("left-posterior-superior", {1, 1, 1})) {
  return "NRRD0004\n# hand-written\ntype: short\ndimension: 3\nsizes: 5 4 3\nendian: little\n"
         "encoding: raw\n" +
         space + extra + (data_file.empty() ? "" : "data file: " + data_file + "\n");
}

/// Writes `text` as name.nhdr next to the fixture's raw data (absolute path) and reads it.
gimm::Volume<std::int16_t> read_header(const std::string& name, const std::string& text) {
  const auto p = tmp(name);
  write_text(p, text);
  return gimm::read_nrrd<std::int16_t>(p);
}

std::string raw_path() {
  return (fixtures::dir() / "ct_nhdr.raw").string();
}

/// The message of read_nrrd<T>'s FormatError for a header (and attached data).
template <class T = float>
std::string nrrd_error(const std::string& name, const std::string& text,
                       const std::vector<unsigned char>& data = {}) {
  const auto p = tmp(name);
  write_text(p, text, data);
  return format_error([&] { (void)gimm::read_nrrd<T>(p); }, p);
}

}  // namespace

TEST_CASE("NRRD files written by plastimatch read as nibabel's NIfTI of the same volume",
          "[io][nrrd]") {
  const auto nifti = gimm::read_nifti<std::int16_t>(fixtures::dir() / "source.nii");
  CHECK(fixture_difference(nifti) == "");
  for (const char* name : {"ct.nrrd", "ct_nhdr.nhdr"}) {
    INFO(name);
    const auto p = fixtures::dir() / name;
    const auto v = gimm::read_nrrd<std::int16_t>(p);
    CHECK(fixture_difference(v) == "");
    CHECK(v.storage() == nifti.storage());
    CHECK((v.origin() - nifti.origin()).cwiseAbs().maxCoeff() < 1e-6);
    CHECK((v.spacing() - nifti.spacing()).cwiseAbs().maxCoeff() < 1e-6);
    CHECK((v.direction() - nifti.direction()).cwiseAbs().maxCoeff() < 1e-6);
    const auto h = gimm::read_nrrd_header(p);
    CHECK(h.space == "left-posterior-superior");
    CHECK(h.data.compression == (std::string(name) == "ct.nrrd" ? gimm::VoxelCompression::gzip
                                                                : gimm::VoxelCompression::none));
    // Any voxel type: the same values.
    CHECK(fixture_difference(gimm::read_nrrd<float>(p)) == "");
  }
}

TEST_CASE("NRRD spaces RAS and LAS map to LPS; a wrong space or flipped axis is seen",
          "[io][nrrd]") {
  CHECK(fixture_difference(read_header("lps.nhdr", header(raw_path()))) == "");
  for (const auto& [space, flip] :
       {std::pair<std::string, Eigen::Vector3d>{"right-anterior-superior", {-1, -1, 1}},
        {"RAS", {-1, -1, 1}},
        {"left-anterior-superior", {1, -1, 1}},
        {"LAS", {1, -1, 1}},
        {"LPS", {1, 1, 1}},
        {"3D-right-handed", {1, 1, 1}}}) {
    INFO(space);
    CHECK(fixture_difference(
              read_header("space.nhdr", header(raw_path(), "", space_fields(space, flip)))) == "");
  }
  // "space dimension: 3" names no space: taken as LPS, as ITK does.
  CHECK(fixture_difference(
            read_header("space_dimension.nhdr",
                        fixtures::replaced(header(raw_path()), "space: left-posterior-superior",
                                           "space dimension: 3"))) == "");
  // RAS vectors labelled LPS, or LPS vectors labelled LAS: the geometry must differ.
  CHECK(fixture_difference(read_header(
            "mislabelled.nhdr",
            header(raw_path(), "", space_fields("left-posterior-superior", {-1, -1, 1})))) != "");
  CHECK(fixture_difference(read_header(
            "mislabelled.nhdr",
            header(raw_path(), "", space_fields("left-anterior-superior", {1, 1, 1})))) != "");
  // One axis flipped in plastimatch's own header.
  const std::string text = fixtures::read_text(fixtures::dir() / "ct_nhdr.nhdr");
  const std::string flipped =
      fixtures::replaced(text, "(-0.65669625847708324,-0.31502333211547123,-0.17891429323859293)",
                         "(0.65669625847708324,0.31502333211547123,0.17891429323859293)");
  CHECK(fixture_difference(
            read_header("flipped.nhdr", fixtures::replaced(flipped, "data file: ct_nhdr.raw",
                                                           "data file: " + raw_path()))) != "");
}

TEST_CASE("NRRD big endian, gzip detached, byte skip and line skip", "[io][nrrd]") {
  const auto raw = fixtures::raw_int16();
  const auto be = tmp("be.raw");
  fixtures::write_bytes(be, fixtures::swapped16(raw));
  const std::string big = fixtures::replaced(header(be.string()), "endian: little", "endian: big");
  CHECK(fixture_difference(read_header("be.nhdr", big)) == "");
  CHECK(fixture_difference(read_header("be_as_little.nhdr", header(be.string()))) != "");

  const auto gz = tmp("data.raw.gz");
  const auto packed = gimm::gzip_compress(raw.data(), raw.size());
  fixtures::write_bytes(gz, packed);
  for (const char* encoding : {"gzip", "gz"}) {
    INFO(encoding);
    const std::string text = fixtures::replaced(header("data.raw.gz"), "encoding: raw",
                                                std::string("encoding: ") + encoding);
    CHECK(fixture_difference(read_header("gz.nhdr", text)) == "");  // relative to the header
  }

  // byte skip -1: the voxels are the last bytes of the file; raw and gzip (of the inflated data).
  std::vector<unsigned char> junk = {'j', 'u', 'n', 'k', '!', '!', '\n'};
  auto with_junk = junk;
  with_junk.insert(with_junk.end(), raw.begin(), raw.end());
  const auto skipped = tmp("skip.raw");
  fixtures::write_bytes(skipped, with_junk);
  CHECK(fixture_difference(read_header("skip.nhdr", header(skipped.string(), "byte skip: -1\n"))) ==
        "");
  CHECK(fixture_difference(read_header("skip.nhdr", header(skipped.string(), "byte skip: 7\n"))) ==
        "");
  CHECK(fixture_difference(read_header("skip.nhdr", header(skipped.string(), "line skip: 1\n"))) ==
        "");
  const auto skipped_gz = tmp("skip.raw.gz");
  fixtures::write_bytes(skipped_gz, gimm::gzip_compress(with_junk.data(), with_junk.size()));
  const std::string gz_skip =
      fixtures::replaced(header(skipped_gz.string(), "byte skip: -1\n"), "raw\n", "gzip\n");
  CHECK(fixture_difference(read_header("skip_gz.nhdr", gz_skip)) == "");
  CHECK(fixture_difference(read_header(
            "skip_gz.nhdr", fixtures::replaced(gz_skip, "byte skip: -1", "byte skip: 7"))) == "");
  // Skipping the wrong amount leaves a byte over: an error, not shifted voxels.
  CHECK_THROWS_AS(read_header("skip.nhdr", header(skipped.string(), "byte skip: 6\n")),
                  gimm::FormatError);

  // Attached raw data with CRLF line endings and key/value pairs.
  std::string attached = header("", "a key:=a value\n");
  std::string crlf;
  for (char c : attached) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
  const auto p = tmp("attached.nrrd");
  write_text(p, crlf + "\r\n", raw);
  CHECK(fixture_difference(gimm::read_nrrd<std::int16_t>(p)) == "");
}

TEST_CASE("NRRD reads every teem spelling of the scalar types", "[io][nrrd]") {
  using Value = std::function<double(std::size_t)>;
  const auto check = [](const std::vector<std::string>& names, auto stored, const Value& value) {
    using Stored = decltype(stored);
    for (const auto& name : names) {
      for (const bool big : {false, true}) {
        INFO(name << (big ? " big" : " little"));
        const auto data = tmp("typed.raw");
        fixtures::write_bytes(data, fixtures::stored_bytes<Stored>(big, value));
        std::string text =
            fixtures::replaced(header(data.string()), "type: short", "type: " + name);
        if (big) text = fixtures::replaced(text, "endian: little", "endian: big");
        const auto p = tmp("typed.nhdr");
        write_text(p, text);
        const auto v = gimm::read_nrrd<double>(p);
        REQUIRE(v.size() == 60);
        for (std::size_t n = 0; n < 60; ++n) REQUIRE(v.data()[n] == value(n));
      }
    }
  };
  const Value fixture = fixtures::expected_value;  // -1000 .. 638
  check({"signed char", "int8", "int8_t", "SIGNED CHAR"}, std::int8_t{},
        [](std::size_t n) { return double(n) - 30; });
  check({"uchar", "unsigned char", "uint8", "uint8_t"}, std::uint8_t{},
        [](std::size_t n) { return 4.0 * double(n); });
  check({"short", "short int", "signed short", "signed short int", "int16", "int16_t"},
        std::int16_t{}, fixture);
  check({"ushort", "unsigned short", "unsigned short int", "uint16", "uint16_t"}, std::uint16_t{},
        [&](std::size_t n) { return fixture(n) + 1000; });
  check({"int", "signed int", "int32", "int32_t"}, std::int32_t{},
        [&](std::size_t n) { return fixture(n) * 1000; });
  check({"uint", "unsigned int", "uint32", "uint32_t"}, std::uint32_t{},
        [&](std::size_t n) { return (fixture(n) + 1000) * 1000; });
  check({"float"}, float{}, [&](std::size_t n) { return fixture(n) + 0.5; });
  check({"double"}, double{}, [&](std::size_t n) { return fixture(n) + 0.25; });
}

TEST_CASE("NRRD dimension 4 with a leading or trailing size-1 axis; spacings without space",
          "[io][nrrd]") {
  const auto g = fixtures::expected_geometry();
  std::string dirs;
  for (int a = 0; a < 3; ++a) dirs += " " + fixtures::vec(g.direction.col(a) * g.spacing[a]);
  const std::string common =
      "NRRD0005\ntype: int16\nendian: little\nencoding: raw\n"
      "space: left-posterior-superior\nspace origin: " +
      fixtures::vec(g.origin) + "\ndata file: " + raw_path() + "\n";
  CHECK(fixture_difference(read_header(
            "trailing.nhdr", common +
                                 "dimension: 4\nsizes: 5 4 3 1\nkinds: domain domain domain "
                                 "list\nspace directions:" +
                                 dirs + " none\n")) == "");
  CHECK(fixture_difference(read_header(
            "leading.nhdr", common +
                                "dimension: 4\nsizes: 1 5 4 3\nkinds: scalar domain domain "
                                "domain\nspace directions: none" +
                                dirs + "\n")) == "");
  const std::string msg = nrrd_error(
      "four.nhdr", common + "dimension: 4\nsizes: 5 4 1 3\nspace directions:" + dirs + " none\n");
  CHECK_THAT(msg, Catch::Contains("dimension 4") && Catch::Contains("size 1"));

  // No space fields: the grid from spacings, identity directions, origin 0.
  const auto v = read_header("spacings.nhdr",
                             "NRRD0001\ntype: short\ndimension: 3\nsizes: 5 4 3\nspacings: 0.75 "
                             "0.5 1.25\nendian: little\nencoding: raw\ndata file: " +
                                 raw_path() + "\n");
  CHECK((v.spacing() - g.spacing).norm() < 1e-12);
  CHECK(v.direction() == Eigen::Matrix3d::Identity());
  CHECK(v.origin() == Eigen::Vector3d::Zero());
  CHECK(v.data()[59] == fixtures::expected_value(59));
  const auto v4 = read_header("spacings4.nhdr",
                              "NRRD0004\ntype: short\ndimension: 4\nsizes: 5 4 3 1\nspacings: "
                              "0.75 0.5 1.25 NaN\nendian: little\nencoding: raw\ndata file: " +
                                  raw_path() + "\n");
  CHECK((v4.spacing() - g.spacing).norm() < 1e-12);
}

TEST_CASE("NRRD refuses what it does not read, naming the file, the field and the value",
          "[io][nrrd]") {
  const std::string base = header(raw_path());
  const auto refused = [&](const std::string& from, const std::string& to,
                           const std::vector<std::string>& fragments) {
    const std::string msg = nrrd_error("refused.nhdr", fixtures::replaced(base, from, to));
    for (const auto& f : fragments) CHECK_THAT(msg, Catch::Contains(f));
  };
  refused("encoding: raw", "encoding: bzip2", {"'encoding'", "bzip2", "raw and gzip"});
  refused("encoding: raw", "encoding: ascii", {"'encoding'", "ascii"});
  refused("sizes: 5 4 3\n", "", {"missing field 'sizes'"});
  refused("sizes: 5 4 3", "sizes: 5 4", {"'sizes'", "3 values"});
  refused("sizes: 5 4 3", "sizes: 5 four 3", {"'sizes'", "'four'"});
  refused("type: short", "type: int64", {"'type'", "int64", "64-bit"});
  refused("type: short", "type: block", {"'type'", "block"});
  refused("type: short", "type: char", {"'type'", "'char'"});
  refused("endian: little\n", "", {"missing field 'endian'", "int16"});
  refused("endian: little", "endian: middle", {"'endian'", "middle"});
  refused("dimension: 3", "dimension: 2", {"'dimension'", "2"});
  refused("space: left-posterior-superior", "space: scanner-xyz", {"'space'", "scanner-xyz"});
  refused("space: left-posterior-superior", "space: 3D-left-handed", {"'space'", "3d-left-handed"});
  refused("space: left-posterior-superior", "space: right-anterior-superior-time",
          {"'space'", "right-anterior-superior-time"});
  refused("data file: " + raw_path(), "data file: LIST", {"'data file'", "LIST"});
  refused("data file: " + raw_path(), "data file: slice%03d.raw 1 3 1 2",
          {"'data file'", "slice%03d.raw"});
  refused("encoding: raw", "encoding: raw\nkinds: RGB-color domain domain",
          {"'kinds'", "rgb-color"});
  refused("encoding: raw", "encoding: raw\nspace units: \"cm\" \"cm\" \"cm\"",
          {"'space units'", "cm"});
  refused("encoding: raw", "encoding: raw\nspacings: 1 1 1", {"space direction and a spacing"});
  refused("encoding: raw", "encoding: raw\nfavourite colour: blue",
          {"unknown field 'favourite colour'"});
  refused("encoding: raw", "encoding: raw\nencoding: raw", {"'encoding' appears twice"});
  refused("encoding: raw", "encoding: raw\nbyte skip: -2", {"'byte skip'", "-2"});
  refused("NRRD0004", "NRRD0009", {"NRRD0009"});
  refused("NRRD0004", "P5", {"not a NRRD file"});
  // A sheared grid is not a rotation times spacing.
  const auto g = fixtures::expected_geometry();
  refused(fixtures::vec(g.direction.col(1) * g.spacing[1]),
          fixtures::vec(g.direction.col(1) * g.spacing[1] + g.direction.col(0) * 0.2),
          {"not orthonormal"});
}

TEST_CASE("NRRD data that is short, long, or claimed absurdly large is an error with the sizes",
          "[io][nrrd]") {
  const auto raw = fixtures::raw_int16();
  const auto short_raw = tmp("short.raw");
  fixtures::write_bytes(short_raw, std::vector<unsigned char>(raw.begin(), raw.begin() + 100));
  std::string msg = nrrd_error("short.nhdr", header(short_raw.string()));
  CHECK_THAT(msg, Catch::Contains("truncated") && Catch::Contains("need 120 bytes") &&
                      Catch::Contains("found 100") && Catch::Contains(short_raw.string()));

  // A data file that is not there: the error names the header and its field (it named only
  // the data file).
  const auto gone = tmp("gone.nhdr");
  write_text(gone, header(tmp("gone.raw").string()));
  CHECK_THROWS_AS(gimm::read_nrrd<float>(gone), gimm::IoError);
  CHECK_THROWS_WITH(gimm::read_nrrd<float>(gone),
                    Catch::Contains("gone.nhdr") && Catch::Contains("field 'data file'") &&
                        Catch::Contains("gone.raw") && Catch::Contains("does not exist"));

  // Attached data cut short, and attached data with bytes after the voxels.
  msg = nrrd_error("cut.nrrd", header("") + "\n",
                   std::vector<unsigned char>(raw.begin(), raw.begin() + 119));
  CHECK_THAT(msg, Catch::Contains("truncated") && Catch::Contains("found 119"));
  auto longer = raw;
  longer.push_back(0);
  msg = nrrd_error("long.nrrd", header("") + "\n", longer);
  CHECK_THAT(msg, Catch::Contains("1 bytes beyond the voxel data"));

  // Truncated gzip: the stream ends early.
  const auto packed = gimm::gzip_compress(raw.data(), raw.size());
  const auto cut_gz = tmp("cut.raw.gz");
  fixtures::write_bytes(cut_gz, std::vector<unsigned char>(packed.begin(), packed.end() - 12));
  msg = nrrd_error("cut_gz.nhdr",
                   fixtures::replaced(header(cut_gz.string()), "encoding: raw", "encoding: gzip"));
  CHECK_THAT(msg, Catch::Contains("truncated") && Catch::Contains("need 120 bytes"));

  // 2^40 voxels claimed by a header with 120 bytes of data: refused before allocating.
  const std::string huge =
      fixtures::replaced(header(raw_path()), "sizes: 5 4 3", "sizes: 65536 65536 256");
  msg = nrrd_error("huge.nhdr", huge);
  CHECK_THAT(msg, Catch::Contains("need 2199023255552 bytes") && Catch::Contains("found 120"));
  msg = nrrd_error("huge_gz.nhdr", fixtures::replaced(huge, "encoding: raw", "encoding: gzip"));
  CHECK_THAT(msg, Catch::Contains("2199023255552") && Catch::Contains("inflate"));
  msg = nrrd_error("huge_attached.nrrd",
                   fixtures::replaced(header(""), "sizes: 5 4 3", "sizes: 65536 65536 256") + "\n",
                   std::vector<unsigned char>(40, 0));
  CHECK_THAT(msg, Catch::Contains("2199023255552"));
  // Sizes beyond what any axis can have, and beyond 64 bits.
  msg =
      nrrd_error("wide.nhdr", fixtures::replaced(header(raw_path()), "5 4 3", "1099511627776 1 1"));
  CHECK_THAT(msg, Catch::Contains("'sizes'") && Catch::Contains("1099511627776"));
  msg = nrrd_error("overflow.nhdr",
                   fixtures::replaced(header(raw_path()), "5 4 3", "99999999999999999999999 1 1"));
  CHECK_THAT(msg, Catch::Contains("'sizes'") && Catch::Contains("99999999999999999999999"));
}

TEST_CASE("NRRD into an integer type refuses values that are not integers in range", "[io][nrrd]") {
  auto values = fixtures::stored_bytes<float>(false);
  const float half = 1.5f;
  std::memcpy(values.data() + 4, &half, 4);  // voxel 1
  const auto data = tmp("float.raw");
  fixtures::write_bytes(data, values);
  const std::string text = fixtures::replaced(header(data.string()), "type: short", "type: float");
  const std::string msg = nrrd_error<std::int16_t>("float.nhdr", text);
  CHECK_THAT(
      msg, Catch::Contains("voxel 1") && Catch::Contains("1.5") && Catch::Contains("does not fit"));
  // Integral floats are fine in int16, and -1000 does not fit uint8.
  fixtures::write_bytes(data, fixtures::stored_bytes<float>(false));
  CHECK(fixture_difference(read_header("float.nhdr", text)) == "");
  CHECK_THAT(nrrd_error<std::uint8_t>("float.nhdr", text), Catch::Contains("voxel 0"));
}

}  // namespace nrrd_test
