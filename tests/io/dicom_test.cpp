// X-ray angiography DICOM in (io/dicom.hpp). The files are written here with GDCM's own writer,
// tag by tag, not with gimm's write_xa_dicom, so a tag read from the wrong place fails.
#include <gdcmImageChangeTransferSyntax.h>
#include <gdcmImageWriter.h>
#include <gdcmReader.h>
#include <gdcmWriter.h>

#include <catch2/catch.hpp>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "gimm/geometry/epipolar.hpp"
#include "gimm/io/dicom.hpp"
#include "gimm/labels/views.hpp"
#include "gimm/pipeline/dicom_pair.hpp"

namespace fs = std::filesystem;

namespace {

fs::path tmp(const std::string& name) {
  fs::create_directories(fs::path(GIMM_TEST_TMP) / "dicom");
  return fs::path(GIMM_TEST_TMP) / "dicom" / name;
}

/// Writes `bytes` to tmp(name) and returns read_xa_dicom's error on it ("" if it reads).
std::string refusal(const std::string& name, const std::string& bytes) {
  std::ofstream(tmp(name), std::ios::binary) << bytes;
  try {
    gimm::read_xa_dicom(tmp(name).string());
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

/// What a test file holds. Pixel (r, c) of frame f is value(f, r, c).
struct Spec {
  int rows = 6, cols = 8, frames = 1, bits = 16;
  bool monochrome1 = false;
  gdcm::TransferSyntax::TSType syntax = gdcm::TransferSyntax::ExplicitVRLittleEndian;
  std::string modality = "XA";
  /// (group, element) -> (VR, value); the geometry of a plain XA file by default.
  std::map<std::pair<std::uint16_t, std::uint16_t>, std::pair<gdcm::VR::VRType, std::string>> tags =
      {{{0x0018, 0x1510}, {gdcm::VR::DS, "-31.5"}},    {{0x0018, 0x1511}, {gdcm::VR::DS, "22.25"}},
       {{0x0018, 0x1110}, {gdcm::VR::DS, "1100"}},     {{0x0018, 0x1111}, {gdcm::VR::DS, "765.5"}},
       {{0x0018, 0x1164}, {gdcm::VR::DS, "0.3\\0.2"}}, {{0x0018, 0x5100}, {gdcm::VR::CS, "HFS"}}};
  /// Even frames grow along the rows, odd frames shrink: frames are told apart by their order.
  static int value(int f, int r, int c) {
    return f % 2 ? 1000 + f - 10 * r - c : 100 * f + 10 * r + c;
  }
};

void write_spec(const fs::path& path, const Spec& spec) {
  gimm::detail::quiet_gdcm();  // GDCM would print its notes on files it is asked to write
  // The image lives in the writer: GDCM's smart pointers would free an image on the stack.
  gdcm::ImageWriter writer;
  gdcm::Image& image = writer.GetImage();
  image.SetNumberOfDimensions(spec.frames > 1 ? 3 : 2);
  image.SetDimension(0, unsigned(spec.cols));
  image.SetDimension(1, unsigned(spec.rows));
  if (spec.frames > 1) image.SetDimension(2, unsigned(spec.frames));
  image.SetPixelFormat(spec.bits == 8 ? gdcm::PixelFormat::UINT8 : gdcm::PixelFormat::UINT16);
  image.SetPhotometricInterpretation(spec.monochrome1
                                         ? gdcm::PhotometricInterpretation::MONOCHROME1
                                         : gdcm::PhotometricInterpretation::MONOCHROME2);
  image.SetTransferSyntax(gdcm::TransferSyntax::ExplicitVRLittleEndian);
  std::vector<char> bytes;
  for (int f = 0; f < spec.frames; ++f)
    for (int r = 0; r < spec.rows; ++r)
      for (int c = 0; c < spec.cols; ++c) {
        const int v = Spec::value(f, r, c);
        if (spec.bits == 8) {
          bytes.push_back(char(std::uint8_t(v % 256)));
        } else {
          bytes.push_back(char(v & 0xff));
          bytes.push_back(char(v >> 8));
        }
      }
  gdcm::DataElement pixels(gdcm::Tag(0x7fe0, 0x0010));
  pixels.SetByteValue(bytes.data(), std::uint32_t(bytes.size()));
  image.SetDataElement(pixels);
  gdcm::ImageChangeTransferSyntax change;  // outlives the writer's use of its output
  if (spec.syntax != gdcm::TransferSyntax::ExplicitVRLittleEndian) {
    change.SetTransferSyntax(spec.syntax);
    change.SetInput(image);
    REQUIRE(change.Change());
    writer.SetImage(change.GetOutput());
  }
  // GDCM's image writer writes the image's spacing as ImagerPixelSpacing: the tags are set on
  // a second pass, through the plain writer, so that each is exactly what the spec says.
  std::stringstream encoded;
  writer.SetStream(encoded);
  REQUIRE(writer.Write());
  gdcm::Reader again;
  again.SetStream(encoded);
  REQUIRE(again.Read());
  gdcm::DataSet& ds = again.GetFile().GetDataSet();
  ds.Remove(gdcm::Tag(0x0018, 0x1164));
  auto tags = spec.tags;
  tags[{0x0008, 0x0060}] = {gdcm::VR::CS, spec.modality};
  tags[{0x0008, 0x0016}] = {
      gdcm::VR::UI, gdcm::MediaStorage::GetMSString(
                        spec.modality == "CT" ? gdcm::MediaStorage::CTImageStorage
                                              : gdcm::MediaStorage::XRayAngiographicImageStorage)};
  for (const auto& [key, vr_value] : tags) {
    std::string value = vr_value.second;
    if (value.size() % 2) value += vr_value.first == gdcm::VR::UI ? '\0' : ' ';
    gdcm::DataElement de(gdcm::Tag(key.first, key.second));
    de.SetVR(vr_value.first);
    de.SetByteValue(value.data(), std::uint32_t(value.size()));
    ds.Replace(de);
  }
  gdcm::Writer out;
  out.SetFile(again.GetFile());
  out.SetFileName(path.c_str());
  REQUIRE(out.Write());
}

/// The stored values of the frame read back: the reader windows by percentiles, so compare
/// orders, not values: the frame read must rank its pixels as `expected` does.
void check_same_order(const gimm::Image<float>& got,
                      const std::vector<std::vector<int>>& expected) {
  REQUIRE(got.rows() == int(expected.size()));
  REQUIRE(got.cols() == int(expected[0].size()));
  for (int r = 0; r < got.rows(); ++r)
    for (int c = 0; c + 1 < got.cols(); ++c) {
      const int e0 = expected[std::size_t(r)][std::size_t(c)];
      const int e1 = expected[std::size_t(r)][std::size_t(c + 1)];
      if (e0 < e1) CHECK(got(r, c) <= got(r, c + 1));
      if (e0 > e1) CHECK(got(r, c) >= got(r, c + 1));
    }
}

std::vector<std::vector<int>> frame_values(const Spec& spec, int f) {
  std::vector<std::vector<int>> out(std::size_t(spec.rows),
                                    std::vector<int>(std::size_t(spec.cols)));
  for (int r = 0; r < spec.rows; ++r)
    for (int c = 0; c < spec.cols; ++c)
      out[std::size_t(r)][std::size_t(c)] = Spec::value(f, r, c) % (spec.bits == 8 ? 256 : 65536);
  return out;
}

}  // namespace

TEST_CASE("DICOM: each geometry tag lands in its CArm field", "[io][dicom]") {
  const Spec spec;
  write_spec(tmp("plain.dcm"), spec);
  const gimm::XaFrame f = gimm::read_xa_dicom(tmp("plain.dcm").string());
  CHECK(f.carm.primary_deg == -31.5);
  CHECK(f.carm.secondary_deg == 22.25);
  CHECK(f.carm.sid_mm == 1100);
  CHECK(f.carm.sod_mm == 765.5);
  CHECK(f.carm.rows == 6);
  CHECK(f.carm.cols == 8);
  // ImagerPixelSpacing is row spacing \ column spacing: 0.3 mm down the rows, 0.2 across.
  CHECK(f.carm.pixel_mm == 0.2);
  CHECK(f.carm.row_pixel_mm() == 0.3);
  const gimm::Camerad camera = f.carm.camera();
  CHECK(camera.K()(0, 0) == Approx(1100 / 0.2));
  CHECK(camera.K()(1, 1) == Approx(-1100 / 0.3));
  CHECK(camera.K()(0, 2) == Approx(3.5));  // the image centre, (cols - 1) / 2
  CHECK(camera.K()(1, 2) == Approx(2.5));
  CHECK(f.carm.patient_position == gimm::PatientPosition::HFS);
  CHECK(f.table_source == "none");
  CHECK(f.carm.table_shift().isZero());
  CHECK(f.warnings.empty());
  // Every tag looked at is reported; the missing ones say so.
  const std::string report = gimm::explain(f);
  CHECK_THAT(report, Catch::Contains("(0018,1510) PositionerPrimaryAngle = -31.5"));
  CHECK_THAT(report, Catch::Contains("(0018,1162) IntensifierSize = absent"));
  CHECK_THAT(report, Catch::Contains("(300A,0128) TableTopVerticalPosition = absent"));
}

TEST_CASE("DICOM: a written C-arm reads back as the same camera", "[io][dicom]") {
  gimm::CArm carm;
  carm.primary_deg = -27.5;
  carm.secondary_deg = 18.125;
  carm.sid_mm = 1195.5;
  carm.sod_mm = 810.25;
  carm.rows = 40;
  carm.cols = 48;
  carm.pixel_mm = 0.3125;
  carm.table_mm = {12.5, -40.25, 310};
  gimm::Image<float> image(carm.rows, carm.cols);
  for (int r = 0; r < carm.rows; ++r)
    for (int c = 0; c < carm.cols; ++c) image(r, c) = float(r * carm.cols + c) / 2000.0f;
  for (bool ge : {false, true}) {
    const fs::path path = tmp(ge ? "roundtrip_ge.dcm" : "roundtrip.dcm");
    gimm::write_xa_dicom(path.string(), image, carm, ge);
    gimm::XaFrame f = gimm::read_xa_dicom(path.string());
    CHECK_THAT(f.table_source, Catch::Contains(ge ? "DLX_SERIE_01" : "standard (300A,0128-012A)"));
    CHECK((f.carm.table_mm - carm.table_mm).norm() == 0);
    // Against a reference view with the table at zero, the patient moved with the table.
    f.carm.reference_table_mm.setZero();
    const gimm::Camerad expected = carm.camera(), got = f.carm.camera();
    double worst = 0;
    for (const Eigen::Vector3d& X :
         {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(40, -30, 60), Eigen::Vector3d(-55, 20, 330)})
      worst = std::max(worst, (expected.project(X).uv - got.project(X).uv).norm());
    CHECK(worst < 1e-9);
    CHECK((f.image.data()[1000] < f.image.data()[1001]));
  }
}

/// The pixel a world point lands on, by hand for an AP view (primary 0, secondary 0): the source
/// is posterior at iso + (0, SOD, 0), the detector anterior; the patient's left (+x) is on the
/// image's right (+u) and the head (+z) at the top (-v). A point (y - iso.y) mm posterior of the
/// isocentre is that much nearer the source: magnification SID / (SOD - (y - iso.y)).
Eigen::Vector2d ap_pixel_by_hand(const Eigen::Vector3d& X, const Eigen::Vector3d& iso, double sid,
                                 double sod, double pitch, int rows, int cols) {
  const double m = sid / (sod - (X.y() - iso.y())) / pitch;  // px per mm at the point
  return {(cols - 1) / 2.0 + m * (X.x() - iso.x()), (rows - 1) / 2.0 - m * (X.z() - iso.z())};
}

TEST_CASE("DICOM: the table moves the patient, the isocentre goes the other way (HFS, GE)",
          "[io][dicom]") {
  // Real GE DL files: (0019,0010) is DLX_SERIE_01, which owns (0019,10xx) and so the table at
  // (0019,1021) vertical, (0019,1022) longitudinal, (0019,1023) lateral; (0019,0011) is
  // GEMS_DL_IMG_01, owning (0019,11xx), where (0019,1121-1123) mean something else.
  Spec a, b;
  a.tags[{0x0018, 0x1510}] = {gdcm::VR::DS, "0"};  // AP: the hand projection above
  a.tags[{0x0018, 0x1511}] = {gdcm::VR::DS, "0"};
  a.tags[{0x0018, 0x1164}] = {gdcm::VR::DS, "0.25\\0.25"};
  a.tags[{0x0019, 0x0010}] = {gdcm::VR::LO, "DLX_SERIE_01"};
  a.tags[{0x0019, 0x0011}] = {gdcm::VR::LO, "GEMS_DL_IMG_01"};
  a.tags[{0x0019, 0x1021}] = {gdcm::VR::DS, "100"};   // vertical
  a.tags[{0x0019, 0x1022}] = {gdcm::VR::DS, "-200"};  // longitudinal
  a.tags[{0x0019, 0x1023}] = {gdcm::VR::DS, "5"};     // lateral
  a.tags[{0x0019, 0x1121}] = {gdcm::VR::DS, "999"};   // GEMS_DL_IMG_01's, not the table
  a.tags[{0x0019, 0x1122}] = {gdcm::VR::DS, "999"};
  a.tags[{0x0019, 0x1123}] = {gdcm::VR::DS, "999"};
  b.tags = a.tags;
  b.tags[{0x0019, 0x1021}] = {gdcm::VR::DS, "110"};   // +10 vertical
  b.tags[{0x0019, 0x1022}] = {gdcm::VR::DS, "-170"};  // +30 longitudinal
  b.tags[{0x0019, 0x1023}] = {gdcm::VR::DS, "-2"};    // -7 lateral
  write_spec(tmp("table_a.dcm"), a);
  write_spec(tmp("table_b.dcm"), b);
  const gimm::XaFrame fa = gimm::read_xa_dicom(tmp("table_a.dcm").string());
  gimm::XaFrame fb = gimm::read_xa_dicom(tmp("table_b.dcm").string());
  CHECK(fb.carm.table_mm == Eigen::Vector3d(-2, 110, -170));  // lateral, vertical, longitudinal
  CHECK_THAT(fb.table_source, Catch::Contains("DLX_SERIE_01") && Catch::Contains("(0019,0010)") &&
                                  Catch::Contains("(0019,1021)"));
  for (const auto& w : fb.warnings) INFO(w);
  CHECK(fb.warnings.empty());
  gimm::set_table_reference(fb, fa);
  // By hand: the table (and the patient on it) moved by (-7 lateral, +10 vertical, +30
  // longitudinal) = (-7, +10, +30) in patient x, y, z. The patient point now at the room's
  // isocentre is the one that was at -(-7, 10, 30) = (7, -10, -30).
  const Eigen::Vector3d now_at_iso(7, -10, -30);
  const gimm::Camerad cb = fb.carm.camera();
  const double sid = 1100, sod = 765.5;
  CHECK((cb.project(now_at_iso).uv - Eigen::Vector2d(3.5, 2.5)).norm() < 1e-9);
  for (const Eigen::Vector3d& X : {Eigen::Vector3d(20, 5, -40), Eigen::Vector3d(-15, -30, 60)})
    CHECK((cb.project(X).uv - ap_pixel_by_hand(X, now_at_iso, sid, sod, 0.25, 6, 8)).norm() < 1e-9);
  CHECK(fa.carm.view_isocenter() == Eigen::Vector3d::Zero());
  // Feet first: the patient's left is the table's right and the head its foot end, so lateral
  // and longitudinal turn round, vertical does not: the patient moved (7, 10, -30).
  fb.carm.patient_position = gimm::PatientPosition::FFS;
  CHECK(fb.carm.view_isocenter() == Eigen::Vector3d(-7, -10, 30));
  // The explain report names the creator, the values and the shift applied.
  fb.carm.patient_position = gimm::PatientPosition::HFS;
  const std::string report = gimm::explain(fb);
  CHECK_THAT(report, Catch::Contains("(0019,0010) PrivateCreator = DLX_SERIE_01") &&
                         Catch::Contains("(0019,1023) TableLateralPosition = -2") &&
                         Catch::Contains("the patient moved (-7, 10, 30)") &&
                         Catch::Contains("= (7, -10, -30) mm"));

  // Implicit VR, as GE writes them: the private tags come back without a VR (UN), their bytes
  // the decimal strings.
  Spec implicit = b;
  implicit.syntax = gdcm::TransferSyntax::ImplicitVRLittleEndian;
  write_spec(tmp("table_implicit.dcm"), implicit);
  const gimm::XaFrame fi = gimm::read_xa_dicom(tmp("table_implicit.dcm").string());
  CHECK_THAT(fi.table_source, Catch::Contains("DLX_SERIE_01"));
  CHECK(fi.carm.table_mm == Eigen::Vector3d(-2, 110, -170));

  // The creator's block, not its place: DLX_SERIE_01 at (0019,0012) owns (0019,12xx).
  Spec moved = a;
  for (std::uint16_t e : {0x0010, 0x0011, 0x1021, 0x1022, 0x1023, 0x1121, 0x1122, 0x1123})
    moved.tags.erase({0x0019, e});
  moved.tags[{0x0019, 0x0010}] = {gdcm::VR::LO, "GEMS_DL_IMG_01"};
  moved.tags[{0x0019, 0x0012}] = {gdcm::VR::LO, "DLX_SERIE_01"};
  moved.tags[{0x0019, 0x1021}] = {gdcm::VR::DS, "555"};  // GEMS_DL_IMG_01's: not the table
  moved.tags[{0x0019, 0x1221}] = {gdcm::VR::DS, "1"};
  moved.tags[{0x0019, 0x1222}] = {gdcm::VR::DS, "2"};
  moved.tags[{0x0019, 0x1223}] = {gdcm::VR::DS, "3"};
  write_spec(tmp("table_block12.dcm"), moved);
  const gimm::XaFrame fm = gimm::read_xa_dicom(tmp("table_block12.dcm").string());
  CHECK(fm.carm.table_mm == Eigen::Vector3d(3, 1, 2));
  CHECK_THAT(fm.table_source, Catch::Contains("(0019,0012)") && Catch::Contains("(0019,1221)"));

  // A creator that only starts like GE's is not GE's table (the standard's rule is the whole
  // value), and table-like tags under a creator gimm does not know are named in a warning.
  Spec other = a;
  other.tags[{0x0019, 0x0010}] = {gdcm::VR::LO, "DLX_SERIE_01X"};
  write_spec(tmp("table_other.dcm"), other);
  const gimm::XaFrame fo = gimm::read_xa_dicom(tmp("table_other.dcm").string());
  CHECK(fo.table_source == "none");
  CHECK(fo.carm.table_mm.isZero());
  REQUIRE(fo.warnings.size() == 3);
  CHECK_THAT(fo.warnings[0], Catch::Contains("(0019,1021) = 100") &&
                                 Catch::Contains("DLX_SERIE_01X") &&
                                 Catch::Contains("not used for the table"));

  // GE's frame block, GEMS_DL_FRAME_01 (0025,xx1B-1D), when the series block is absent.
  Spec frame_block;
  frame_block.tags[{0x0025, 0x0010}] = {gdcm::VR::LO, "GEMS_DL_FRAME_01"};
  frame_block.tags[{0x0025, 0x101B}] = {gdcm::VR::DS, "4"};
  frame_block.tags[{0x0025, 0x101C}] = {gdcm::VR::DS, "5"};
  frame_block.tags[{0x0025, 0x101D}] = {gdcm::VR::DS, "6"};
  write_spec(tmp("table_frame_block.dcm"), frame_block);
  const gimm::XaFrame ff = gimm::read_xa_dicom(tmp("table_frame_block.dcm").string());
  CHECK(ff.carm.table_mm == Eigen::Vector3d(6, 4, 5));
  CHECK_THAT(ff.table_source, Catch::Contains("GEMS_DL_FRAME_01"));

  // The standard tags, when no vendor block is there.
  Spec standard;
  standard.tags[{0x300A, 0x0128}] = {gdcm::VR::DS, "7"};
  standard.tags[{0x300A, 0x0129}] = {gdcm::VR::DS, "8"};
  standard.tags[{0x300A, 0x012A}] = {gdcm::VR::DS, "9"};
  write_spec(tmp("table_standard.dcm"), standard);
  const gimm::XaFrame fs_ = gimm::read_xa_dicom(tmp("table_standard.dcm").string());
  CHECK(fs_.table_source == "standard (300A,0128-012A)");
  CHECK(fs_.carm.table_mm == Eigen::Vector3d(9, 7, 8));
}

TEST_CASE("DICOM: the shutters give the exposed field, turned as the pixels are", "[io][dicom]") {
  Spec spec;  // 6 rows x 8 columns; DICOM's shutter coordinates are 1-based rows and columns
  spec.tags[{0x0018, 0x1600}] = {gdcm::VR::CS, "RECTANGULAR"};
  spec.tags[{0x0018, 0x1602}] = {gdcm::VR::IS, "2"};  // left column (1-based): 0-based 1
  spec.tags[{0x0018, 0x1604}] = {gdcm::VR::IS, "7"};  // right: 0-based 6
  spec.tags[{0x0018, 0x1606}] = {gdcm::VR::IS, "3"};  // upper row: 0-based 2
  spec.tags[{0x0018, 0x1608}] = {gdcm::VR::IS, "5"};  // lower: 0-based 4
  write_spec(tmp("shutter_rect.dcm"), spec);
  const gimm::XaFrame f = gimm::read_xa_dicom(tmp("shutter_rect.dcm").string());
  REQUIRE(f.field.rows() == 6);
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 8; ++c)
      CHECK(int(f.field(r, c)) == int(c >= 1 && c <= 6 && r >= 2 && r <= 4));
  CHECK_THAT(f.field_source, Catch::Contains("RECTANGULAR"));

  // Circular and rectangular together: the field is inside both.
  spec.tags[{0x0018, 0x1600}] = {gdcm::VR::CS, "RECTANGULAR\\CIRCULAR"};
  spec.tags[{0x0018, 0x1610}] = {gdcm::VR::IS, "4\\4"};  // centre row 4, column 4 (1-based)
  spec.tags[{0x0018, 0x1612}] = {gdcm::VR::IS, "1"};
  write_spec(tmp("shutter_both.dcm"), spec);
  const gimm::XaFrame both = gimm::read_xa_dicom(tmp("shutter_both.dcm").string());
  int inside = 0;
  for (std::size_t k = 0; k < both.field.size(); ++k) inside += both.field.data()[k];
  CHECK(inside == 5);  // the centre (0-based 3, 3) and its four neighbours
  CHECK(both.field(3, 3) == 1);
  CHECK(both.field(2, 3) == 1);
  CHECK(both.field(2, 2) == 0);

  // Polygonal: a triangle; and the field turns with FieldOfViewRotation as the pixels do.
  Spec poly;
  poly.tags[{0x0018, 0x1600}] = {gdcm::VR::CS, "POLYGONAL"};
  poly.tags[{0x0018, 0x1620}] = {gdcm::VR::IS, "1\\1\\1\\8\\6\\1"};  // row\column pairs
  poly.tags[{0x0018, 0x7032}] = {gdcm::VR::DS, "90"};
  write_spec(tmp("shutter_poly.dcm"), poly);
  const gimm::XaFrame p = gimm::read_xa_dicom(tmp("shutter_poly.dcm").string());
  REQUIRE(p.field.rows() == 8);  // turned: 8 rows x 6 columns
  REQUIRE(p.field.cols() == 6);
  // Stored (0, 0) is a corner inside the triangle, stored (5, 7) is outside; a counter-clockwise
  // quarter turn takes stored (r, c) to (cols - 1 - c, r).
  CHECK(p.field(7 - 0, 0) == 1);
  CHECK(p.field(7 - 7, 5) == 0);

  // Missing edges and unknown shapes are refused, naming the tag.
  Spec bad;
  bad.tags[{0x0018, 0x1600}] = {gdcm::VR::CS, "RECTANGULAR"};
  write_spec(tmp("shutter_bad.dcm"), bad);
  CHECK_THROWS_WITH(gimm::read_xa_dicom(tmp("shutter_bad.dcm").string()),
                    Catch::Contains("shutter_bad.dcm") && Catch::Contains("(0018,1602)"));
  bad.tags[{0x0018, 0x1600}] = {gdcm::VR::CS, "HEXAGONAL"};
  write_spec(tmp("shutter_hex.dcm"), bad);
  CHECK_THROWS_WITH(gimm::read_xa_dicom(tmp("shutter_hex.dcm").string()),
                    Catch::Contains("HEXAGONAL"));
  // No shutter tags: no field from the file.
  Spec none;
  write_spec(tmp("shutter_none.dcm"), none);
  CHECK(gimm::read_xa_dicom(tmp("shutter_none.dcm").string()).field.size() == 0);
}

TEST_CASE("DICOM: colour and frame counts GDCM mishandles are refused before it reads them",
          "[io][dicom]") {
  // PALETTE COLOR aborts the process inside GDCM (an assertion); it must be an error naming the
  // file and the tag, before GDCM sees the pixels.
  Spec palette;
  palette.tags[{0x0028, 0x0004}] = {gdcm::VR::CS, "PALETTE COLOR"};
  write_spec(tmp("palette.dcm"), palette);
  CHECK_THROWS_WITH(gimm::read_xa_dicom(tmp("palette.dcm").string()),
                    Catch::Contains("palette.dcm") && Catch::Contains("(0028,0004)") &&
                        Catch::Contains("PALETTE COLOR"));
  // NumberOfFrames "abc" over 3 frames: GDCM reads 1 frame.
  Spec frames;
  frames.frames = 3;
  frames.tags[{0x0028, 0x0008}] = {gdcm::VR::IS, "abc"};
  write_spec(tmp("frames_abc.dcm"), frames);
  CHECK_THROWS_WITH(gimm::read_xa_dicom(tmp("frames_abc.dcm").string()),
                    Catch::Contains("frames_abc.dcm") && Catch::Contains("(0028,0008)") &&
                        Catch::Contains("'abc'"));
  frames.tags[{0x0028, 0x0008}] = {gdcm::VR::IS, "0"};
  write_spec(tmp("frames_zero.dcm"), frames);
  CHECK_THROWS_WITH(gimm::read_xa_dicom(tmp("frames_zero.dcm").string()),
                    Catch::Contains("(0028,0008)"));
  frames.tags[{0x0028, 0x0008}] = {gdcm::VR::IS, "3"};
  write_spec(tmp("frames_three.dcm"), frames);
  CHECK(gimm::read_xa_dicom(tmp("frames_three.dcm").string()).frames == 3);
}

TEST_CASE("DICOM: frames, bit depths, MONOCHROME1 and compressed syntaxes", "[io][dicom]") {
  SECTION("multi-frame: the middle frame by default, any frame on request") {
    Spec spec;
    spec.frames = 5;
    write_spec(tmp("multi.dcm"), spec);
    const gimm::XaFrame middle = gimm::read_xa_dicom(tmp("multi.dcm").string());
    CHECK(middle.frames == 5);
    CHECK(middle.frame == 2);
    check_same_order(middle.image, frame_values(spec, 2));
    gimm::DicomReadOptions odd;
    odd.frame = 1;
    const gimm::XaFrame second = gimm::read_xa_dicom(tmp("multi.dcm").string(), odd);
    CHECK(second.frame == 1);
    check_same_order(second.image, frame_values(spec, 1));
    CHECK(second.image(0, 1) > second.image(0, 2));  // (0, 0) and (0, 1) clip to 1
    gimm::DicomReadOptions past;
    past.frame = 5;
    CHECK_THROWS_WITH(gimm::read_xa_dicom(tmp("multi.dcm").string(), past),
                      Catch::Contains("multi.dcm") && Catch::Contains("frame 5 is out of range") &&
                          Catch::Contains("0..4"));
  }
  SECTION("8-bit") {
    Spec spec;
    spec.bits = 8;
    write_spec(tmp("8bit.dcm"), spec);
    check_same_order(gimm::read_xa_dicom(tmp("8bit.dcm").string()).image, frame_values(spec, 0));
  }
  SECTION("MONOCHROME1 is inverted: a high stored value reads dark") {
    Spec spec;
    spec.monochrome1 = true;
    write_spec(tmp("mono1.dcm"), spec);
    const gimm::XaFrame f = gimm::read_xa_dicom(tmp("mono1.dcm").string());
    CHECK(f.image(0, 0) > f.image(5, 7));  // stored 0 is white, stored 57 black
    CHECK(f.image(0, 0) == 1.0f);
    CHECK(f.image(5, 7) == 0.0f);
    CHECK_THAT(gimm::explain(f), Catch::Contains("MONOCHROME1  -> inverted"));
  }
  SECTION("RLE, JPEG lossless and JPEG-LS decode to the uncompressed pixels") {
    Spec plain;
    plain.rows = 16;
    plain.cols = 16;
    write_spec(tmp("uncompressed.dcm"), plain);
    const gimm::XaFrame expected = gimm::read_xa_dicom(tmp("uncompressed.dcm").string());
    for (const auto syntax :
         {gdcm::TransferSyntax::RLELossless, gdcm::TransferSyntax::JPEGLosslessProcess14_1,
          gdcm::TransferSyntax::JPEGLSLossless}) {
      Spec spec = plain;
      spec.syntax = syntax;
      const fs::path path = tmp(std::string("syntax_") + std::to_string(int(syntax)) + ".dcm");
      write_spec(path, spec);
      const gimm::XaFrame got = gimm::read_xa_dicom(path.string());
      INFO(gdcm::TransferSyntax::GetTSString(syntax));
      REQUIRE(got.image.rows() == expected.image.rows());
      CHECK(
          std::equal(got.image.data(), got.image.data() + got.image.size(), expected.image.data()));
    }
  }
}

TEST_CASE("DICOM: pixel pitch fallbacks say what they used", "[io][dicom]") {
  Spec spec;
  spec.tags.erase({0x0018, 0x1164});
  write_spec(tmp("no_pitch.dcm"), spec);
  CHECK_THROWS_WITH(gimm::read_xa_dicom(tmp("no_pitch.dcm").string()),
                    Catch::Contains("no_pitch.dcm") && Catch::Contains("(0018,1164)") &&
                        Catch::Contains("(0018,1162)"));
  gimm::DicomReadOptions given;
  given.pitch_mm = 0.25;
  CHECK(gimm::read_xa_dicom(tmp("no_pitch.dcm").string(), given).carm.pixel_mm == 0.25);

  spec.tags[{0x0018, 0x1162}] = {gdcm::VR::DS, "240"};
  write_spec(tmp("intensifier.dcm"), spec);
  const gimm::XaFrame f = gimm::read_xa_dicom(tmp("intensifier.dcm").string());
  CHECK(f.carm.pixel_mm == Approx(240.0 / 8));  // IntensifierSize / Columns
  CHECK(f.carm.pixel_row_mm == 0);
  REQUIRE(f.warnings.size() == 1);
  CHECK_THAT(f.warnings[0], Catch::Contains("IntensifierSize / Columns"));
  // FieldOfViewDimensions' pitch is said beside it, not used (docs/dicom.md, "Pixel pitch").
  spec.tags[{0x0018, 0x1149}] = {gdcm::VR::IS, "200"};
  write_spec(tmp("intensifier_fov.dcm"), spec);
  const gimm::XaFrame g = gimm::read_xa_dicom(tmp("intensifier_fov.dcm").string());
  CHECK(g.carm.pixel_mm == Approx(240.0 / 8));
  REQUIRE(g.warnings.size() == 1);
  CHECK_THAT(g.warnings[0], Catch::Contains("FieldOfViewDimensions / Columns would give 25 mm"));
}

TEST_CASE("DICOM: field-of-view rotation and flip are undone", "[io][dicom]") {
  // Stored = flip(rotate_cw(detector)). A 90-degree turn swaps rows and columns and the pitch.
  Spec spec;
  spec.tags[{0x0018, 0x7032}] = {gdcm::VR::DS, "90"};
  write_spec(tmp("rot90.dcm"), spec);
  const gimm::XaFrame f = gimm::read_xa_dicom(tmp("rot90.dcm").string());
  CHECK(f.carm.rows == 8);
  CHECK(f.carm.cols == 6);
  CHECK(f.carm.pixel_mm == 0.3);  // the stored rows' spacing is now across the columns
  CHECK(f.carm.row_pixel_mm() == 0.2);
  // A clockwise turn puts detector (i, j) at stored (j, rows_d - 1 - i), so stored (r, c) is
  // detector (rows_d - 1 - c, r), rows_d = 8; stored values grow with c.
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c + 1 < 8; ++c)
      CHECK(f.image(8 - 1 - c, r) <= f.image(8 - 1 - (c + 1), r));  // value grows with stored c

  Spec flipped;
  flipped.tags[{0x0018, 0x7034}] = {gdcm::VR::CS, "YES"};
  write_spec(tmp("flip.dcm"), flipped);
  const gimm::XaFrame g = gimm::read_xa_dicom(tmp("flip.dcm").string());
  CHECK(g.image(0, 0) > g.image(0, 7));  // stored values grow to the right; flipped back

  spec.tags[{0x0018, 0x7032}] = {gdcm::VR::DS, "45"};
  write_spec(tmp("rot45.dcm"), spec);
  CHECK_THROWS_WITH(gimm::read_xa_dicom(tmp("rot45.dcm").string()),
                    Catch::Contains("(0018,7032)") && Catch::Contains("45"));
}

TEST_CASE("DICOM: the field of view's place on the detector sets the principal point",
          "[io][dicom]") {
  // A 100 x 120 mm detector of 0.1 mm elements; the image is a 2x-binned field of view whose
  // corner is at detector pixel (row 300, column 350). The detector's centre (499.5, 599.5)
  // is then image (row (499.5 - 300 + 0.5) / 2 - 0.5, column (599.5 - 350 + 0.5) / 2 - 0.5).
  Spec spec;
  spec.tags[{0x0018, 0x1164}] = {gdcm::VR::DS, "0.2\\0.2"};
  spec.tags[{0x0018, 0x7030}] = {gdcm::VR::DS, "300\\350"};
  spec.tags[{0x0018, 0x7026}] = {gdcm::VR::DS, "100\\120"};
  spec.tags[{0x0018, 0x7022}] = {gdcm::VR::DS, "0.1\\0.1"};
  write_spec(tmp("fov.dcm"), spec);
  const gimm::XaFrame f = gimm::read_xa_dicom(tmp("fov.dcm").string());
  REQUIRE(f.carm.principal_point);
  CHECK(f.carm.principal_point->x() == Approx(124.5));  // u = column
  CHECK(f.carm.principal_point->y() == Approx(99.5));   // v = row
}

TEST_CASE("DICOM: bad files fail naming the file and the tag", "[io][dicom]") {
  { std::ofstream(tmp("text.dcm")) << "not a DICOM file at all"; }
  CHECK_THROWS_WITH(gimm::read_xa_dicom(tmp("text.dcm").string()),
                    Catch::Contains("text.dcm") && Catch::Contains("not a DICOM file"));
  CHECK_THROWS_WITH(gimm::read_xa_dicom(tmp("missing.dcm").string()),
                    Catch::Contains("missing.dcm") && Catch::Contains("no such file"));

  Spec ct;
  ct.modality = "CT";
  write_spec(tmp("ct.dcm"), ct);
  CHECK_THROWS_WITH(
      gimm::read_xa_dicom(tmp("ct.dcm").string()),
      Catch::Contains("ct.dcm") && Catch::Contains("(0008,0060)") && Catch::Contains("'CT'"));

  for (const std::uint16_t element : {0x1510, 0x1511, 0x1110, 0x1111}) {
    Spec spec;
    spec.tags.erase({0x0018, element});
    write_spec(tmp("missing_tag.dcm"), spec);
    char tag[16];
    std::snprintf(tag, sizeof tag, "(0018,%04X)", element);
    CHECK_THROWS_WITH(
        gimm::read_xa_dicom(tmp("missing_tag.dcm").string()),
        Catch::Contains("missing_tag.dcm") && Catch::Contains(tag) && Catch::Contains("missing"));
  }

  Spec garbage;
  garbage.tags[{0x0018, 0x1510}] = {gdcm::VR::DS, "left"};
  write_spec(tmp("garbage.dcm"), garbage);
  CHECK_THROWS_WITH(gimm::read_xa_dicom(tmp("garbage.dcm").string()),
                    Catch::Contains("(0018,1510)") && Catch::Contains("'left'"));

  Spec prone;
  prone.tags[{0x0018, 0x5100}] = {gdcm::VR::CS, "HFP"};
  write_spec(tmp("prone.dcm"), prone);
  CHECK_THROWS_WITH(gimm::read_xa_dicom(tmp("prone.dcm").string()),
                    Catch::Contains("(0018,5100)") && Catch::Contains("HFP"));

  Spec no_position;
  no_position.tags.erase({0x0018, 0x5100});
  write_spec(tmp("no_position.dcm"), no_position);
  const auto f = gimm::read_xa_dicom(tmp("no_position.dcm").string());
  REQUIRE(f.warnings.size() == 1);
  CHECK_THAT(f.warnings[0], Catch::Contains("HFS") && Catch::Contains("assumed"));

  // Elements that run past the end of the file or have a VR that is not one, in the file meta
  // group and in the data set, and the other files GDCM (built with assertions) would abort on:
  // gimm refuses them first, naming the element.
  {
    write_spec(tmp("whole.dcm"), Spec{});
    std::ifstream in(tmp("whole.dcm"), std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto sop = bytes.find(std::string("\x02\x00\x03\x00UI", 6));  // (0002,0003)
    REQUIRE(sop != std::string::npos);
    // Cut inside (0002,0003): the group length (0002,0000) promises more than the file holds.
    CHECK_THAT(refusal("cut_meta.dcm", bytes.substr(0, sop + 13)),
               Catch::Contains("cut_meta.dcm") && Catch::Contains("(0002,0000)") &&
                   Catch::Contains("207 bytes"));
    // Without the group length (an optional element: 12 bytes right after "DICM"), the same cut
    // is found at the element, and a file of only a meta group at its end.
    REQUIRE(bytes.compare(132, 6, std::string("\x02\x00\x00\x00UL", 6)) == 0);
    const std::string no_length = bytes.substr(0, 132) + bytes.substr(144);
    CHECK_THAT(refusal("cut_element.dcm", no_length.substr(0, sop - 12 + 13)),
               Catch::Contains("cut_element.dcm") && Catch::Contains("(0002,0003)") &&
                   Catch::Contains("past the end"));
    std::size_t data_set = sop - 12;  // the first (0008,xxxx) element with a VR
    while (data_set + 6 < no_length.size() &&
           !(no_length.compare(data_set, 2, std::string("\x08\x00", 2)) == 0 &&
             std::isupper(static_cast<unsigned char>(no_length[data_set + 4])) &&
             std::isupper(static_cast<unsigned char>(no_length[data_set + 5]))))
      ++data_set;
    CHECK_THAT(refusal("meta_only.dcm", no_length.substr(0, data_set)),
               Catch::Contains("meta_only.dcm") && Catch::Contains("ends inside the file meta"));
    std::string bad_vr = bytes;
    bad_vr[sop + 4] = 'E';  // "EI": two letters, not a VR
    CHECK_THAT(refusal("bad_vr.dcm", bad_vr),
               Catch::Contains("bad_vr.dcm") && Catch::Contains("(0002,0003)") &&
                   Catch::Contains("VR 'EI', which is not a DICOM VR"));
    // The data set: (0018,1510) PositionerPrimaryAngle claims 0x3a08 bytes.
    const auto angle =
        bytes.find(std::string("\x18\x00\x10\x15"
                               "DS",
                               6));
    REQUIRE(angle != std::string::npos);
    std::string long_angle = bytes;
    long_angle[angle + 6] = 0x08;
    long_angle[angle + 7] = 0x3a;
    CHECK_THAT(refusal("long_angle.dcm", long_angle),
               Catch::Contains("long_angle.dcm") && Catch::Contains("(0018,1510)") &&
                   Catch::Contains("14856 bytes, past the end"));
    // The same element with VR bytes that are not letters: GDCM reads it as implicit VR (a
    // 4-byte length, here 0x9B000000) and allocated 2.6 GB for it before gimm refused it first
    // (found by libFuzzer: docs/dev/fuzzing.md).
    std::string implicit_angle = bytes;
    implicit_angle.replace(angle + 4, 4, std::string("\x00\x00\x00\x9B", 4));
    CHECK_THAT(refusal("implicit_angle.dcm", implicit_angle),
               Catch::Contains("implicit_angle.dcm") && Catch::Contains("(0018,1510)") &&
                   Catch::Contains("no VR in an explicit VR data set"));
    // (0008,0016) SOPClassUID renamed (0008,0010), the retired RecognitionCode: GDCM asserts that
    // its value starts "ACR-NEMA" (found by libFuzzer).
    const auto sop_class = bytes.find(std::string("\x08\x00\x16\x00UI", 6));
    REQUIRE(sop_class != std::string::npos);
    std::string recognition = bytes;
    recognition[sop_class + 2] = 0x10;
    CHECK_THAT(refusal("recognition.dcm", recognition), Catch::Contains("recognition.dcm") &&
                                                            Catch::Contains("(0008,0010)") &&
                                                            Catch::Contains("not 'ACR-NEMA"));
    // (0008,0030) StudyTime renamed (0008,0010): out of order, which sends GDCM guessing the
    // byte order (libFuzzer found a 4 GB allocation that way).
    const auto study_time = bytes.find(std::string("\x08\x00\x30\x00TM", 6));
    REQUIRE(study_time != std::string::npos);
    std::string unordered = bytes;
    unordered[study_time + 2] = 0x10;
    CHECK_THAT(refusal("unordered.dcm", unordered), Catch::Contains("unordered.dcm") &&
                                                        Catch::Contains("(0008,0010)") &&
                                                        Catch::Contains("must ascend by tag"));
    // "DICM" followed by something else than the file meta group; a meta group without the
    // transfer syntax (0002,0010) (renamed (0002,0011), still in order).
    std::string shifted = std::string(1, '\0') + bytes;  // "DICM" at byte 129
    CHECK_THAT(refusal("shifted.dcm", shifted),
               Catch::Contains("shifted.dcm") && Catch::Contains("no \"DICM\" prefix"));
    std::string no_meta = bytes;
    no_meta[132] = 0x08;
    CHECK_THAT(refusal("no_meta.dcm", no_meta),
               Catch::Contains("no_meta.dcm") && Catch::Contains("no file meta group"));
    std::string implicit_meta = bytes;  // (0002,0003)'s VR "UI" -> two NULs
    implicit_meta[sop + 4] = implicit_meta[sop + 5] = '\0';
    CHECK_THAT(refusal("implicit_meta.dcm", implicit_meta),
               Catch::Contains("implicit_meta.dcm") && Catch::Contains("(0002,0003)") &&
                   Catch::Contains("must be explicit VR"));
    std::string undefined_meta = bytes;  // (0002,0003) UI -> OB of undefined length
    undefined_meta.replace(sop + 4, 8, std::string("OB\0\0\xff\xff\xff\xff", 8));
    CHECK_THAT(refusal("undefined_meta.dcm", undefined_meta),
               Catch::Contains("undefined_meta.dcm") && Catch::Contains("(0002,0003)") &&
                   Catch::Contains("undefined length"));
    // Rows 6 -> 6000: the header asks for 96,000 bytes of pixels that a 1 KB file cannot hold;
    // refused before the buffer is allocated.
    const auto rows_at = bytes.find(std::string("\x28\x00\x10\x00US\x02\x00\x06\x00", 10));
    REQUIRE(rows_at != std::string::npos);
    std::string tall = bytes;
    tall.replace(rows_at + 8, 2, std::string("\x70\x17", 2));
    CHECK_THAT(refusal("tall.dcm", tall), Catch::Contains("tall.dcm") &&
                                              Catch::Contains("8 x 6000 x 1 frames") &&
                                              Catch::Contains("96000 bytes, more than the"));
    // A sequence of undefined length, (0008,1140) ReferencedImageSequence, with one item of
    // undefined length, put where its tag belongs: read as it is, and refused where an element
    // inside the item runs past the end, or the sequence is not closed.
    const auto patient = bytes.find(std::string("\x10\x00\x10\x00PN", 6));
    REQUIRE(patient != std::string::npos);
    const auto with_sequence = [&](const std::string& inner_length, bool closed) {
      const std::string item_data = std::string("\x08\x00\x50\x11UI", 6) + inner_length + "1.2";
      std::string sequence = std::string("\x08\x00\x40\x11SQ\0\0\xff\xff\xff\xff", 12) +
                             std::string("\xfe\xff\x00\xe0\xff\xff\xff\xff", 8) + item_data +
                             std::string(1, '\0') + std::string("\xfe\xff\x0d\xe0\0\0\0\0", 8);
      if (closed) sequence += std::string("\xfe\xff\xdd\xe0\0\0\0\0", 8);
      std::string out = bytes;
      out.insert(patient, sequence);
      return out;
    };
    std::ofstream(tmp("sequence.dcm"), std::ios::binary)
        << with_sequence(std::string("\x04\x00", 2), true);
    CHECK(gimm::read_xa_dicom(tmp("sequence.dcm").string()).image.rows() == 6);
    std::ofstream(tmp("sequence_long.dcm"), std::ios::binary)
        << with_sequence(std::string("\xf0\xff", 2), true);
    CHECK_THROWS_WITH(gimm::read_xa_dicom(tmp("sequence_long.dcm").string()),
                      Catch::Contains("sequence_long.dcm") && Catch::Contains("(0008,1150)") &&
                          Catch::Contains("65520 bytes, past the end"));
    std::ofstream(tmp("sequence_open.dcm"), std::ios::binary)
        << with_sequence(std::string("\x04\x00", 2), false);
    CHECK_THROWS_WITH(gimm::read_xa_dicom(tmp("sequence_open.dcm").string()),
                      Catch::Contains("sequence_open.dcm") && Catch::Contains("(0010,0010)") &&
                          Catch::Contains("where an item (FFFE,E000) is expected"));
    for (const auto& [uid, message] :
         {std::pair<std::string, std::string>{"1.2.840.10008.1.2.2", "explicit VR big endian"},
          {"1.2.840.10008.1.2.7", "unknown transfer syntax"}}) {
      std::string other = bytes;
      const auto explicit_le = other.find("1.2.840.10008.1.2.1");
      REQUIRE(explicit_le != std::string::npos);
      other.replace(explicit_le, uid.size(), uid + std::string(19 - uid.size(), '\0'));
      CHECK_THAT(refusal("syntax.dcm", other),
                 Catch::Contains("syntax.dcm") && Catch::Contains(uid) && Catch::Contains(message));
    }
    const auto syntax_uid = bytes.find(std::string("\x02\x00\x10\x00UI", 6));
    REQUIRE(syntax_uid != std::string::npos);
    std::string no_syntax = bytes;
    no_syntax[syntax_uid + 2] = 0x11;
    CHECK_THAT(refusal("no_syntax.dcm", no_syntax),
               Catch::Contains("no_syntax.dcm") && Catch::Contains("(0002,0010)"));
    const auto spp = bytes.find(std::string("\x28\x00\x02\x00US\x02\x00", 8));
    REQUIRE(spp != std::string::npos);
    std::string many_samples = bytes;
    many_samples[spp + 8] = 9;
    CHECK_THAT(refusal("samples.dcm", many_samples),
               Catch::Contains("(0028,0002)") && Catch::Contains("is 9"));
    // Columns (0028,0011) as UL, and Rows (0028,0010) as a 4-byte US (found by libFuzzer: an
    // assertion in GDCM's ImageHelper::GetDimensionsValue).
    const auto columns = bytes.find(std::string("\x28\x00\x11\x00US\x02\x00", 8));
    REQUIRE(columns != std::string::npos);
    std::string columns_ul = bytes;
    columns_ul[columns + 5] = 'L';
    CHECK_THAT(refusal("columns_ul.dcm", columns_ul), Catch::Contains("columns_ul.dcm") &&
                                                          Catch::Contains("(0028,0011)") &&
                                                          Catch::Contains("VR UL"));
    // A presentation state's SOP class (known to GDCM, not an image) in the file meta group,
    // an unknown one in the data set (libFuzzer: an assertion in PixmapReader::Read).
    for (const auto& [tag, element] :
         {std::pair<std::string, std::string>{std::string("\x02\x00\x02\x00UI", 6), "(0002,0002)"},
          {std::string("\x08\x00\x16\x00UI", 6), "(0008,0016)"}}) {
      const auto sop_class = bytes.find(tag + std::string("\x1c\x00", 2));
      REQUIRE(sop_class != std::string::npos);
      std::string other = bytes;  // ...1.12.1 (XA) -> ...1.11.1 (GSPS)
      REQUIRE(other.compare(sop_class + 8, 28, "1.2.840.10008.5.1.4.1.1.12.1") == 0);
      other[sop_class + 8 + 25] = '1';
      CHECK_THAT(refusal("sop_class.dcm", other),
                 Catch::Contains("sop_class.dcm") && Catch::Contains(element) &&
                     Catch::Contains("not an image storage class"));
    }
    // Any geometry or pixel element under a VR its dictionary entry does not allow (libFuzzer:
    // FrameIncrementPointer (0028,0009), an assertion in gdcm::Attribute::SetFromDataElement).
    const auto primary =
        bytes.find(std::string("\x18\x00\x10\x15"
                               "DS",
                               6));
    REQUIRE(primary != std::string::npos);
    std::string primary_ul = bytes;
    primary_ul[primary + 4] = 'U';
    primary_ul[primary + 5] = 'L';
    CHECK_THAT(refusal("primary_ul.dcm", primary_ul),
               Catch::Contains("primary_ul.dcm") && Catch::Contains("(0018,1510)") &&
                   Catch::Contains("VR UL where the DICOM dictionary says DS"));
    // Native pixel data 2 bytes short of the frame (libFuzzer + ASan: GDCM read past it).
    const auto pixels = bytes.rfind(std::string("\xe0\x7f\x10\x00OW\x00\x00", 8));
    REQUIRE(pixels != std::string::npos);
    std::string short_pixels = bytes.substr(0, bytes.size() - 2);
    std::uint32_t pixel_length = 0;
    std::memcpy(&pixel_length, short_pixels.data() + pixels + 8, 4);
    pixel_length -= 2;
    std::memcpy(short_pixels.data() + pixels + 8, &pixel_length, 4);
    CHECK_THAT(refusal("short_pixels.dcm", short_pixels),
               Catch::Contains("short_pixels.dcm") && Catch::Contains("(7FE0,0010)") &&
                   Catch::Contains("holds " + std::to_string(pixel_length) + " bytes"));
    // Rows renamed NumberOfFrames (0028,0008), so an IS element with VR US (libFuzzer again:
    // an assertion in GDCM's Attribute<0028,0008>::SetFromDataElement).
    const auto rows = bytes.find(std::string("\x28\x00\x10\x00US\x02\x00", 8));
    REQUIRE(rows != std::string::npos);
    std::string frames_us = bytes;
    frames_us[rows + 2] = 0x08;
    CHECK_THAT(refusal("frames_us.dcm", frames_us),
               Catch::Contains("(0028,0008)") && Catch::Contains("VR US"));
    REQUIRE(rows != std::string::npos);
    std::string rows_long = bytes;  // 4 bytes: the value and the next element's first two
    rows_long[rows + 6] = 4;
    CHECK_THAT(refusal("rows_long.dcm", rows_long),
               Catch::Contains("(0028,0010)") && Catch::Contains("4 bytes"));
    CHECK_THAT(refusal("tail.dcm", bytes + "tail"), Catch::Contains("tail.dcm") &&
                                                        Catch::Contains("4 bytes after element") &&
                                                        Catch::Contains("(7FE0,0010)"));
  }

  // A compressed syntax this build cannot decode: JPEG-LS pixels under the JPIP-referenced
  // transfer syntax UID (same length, so only the UID changes).
  Spec jpls;
  jpls.syntax = gdcm::TransferSyntax::JPEGLSLossless;
  write_spec(tmp("jpls.dcm"), jpls);
  std::ifstream in(tmp("jpls.dcm"), std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string from = "1.2.840.10008.1.2.4.80", to = "1.2.840.10008.1.2.4.94";
  const auto at = bytes.find(from);
  REQUIRE(at != std::string::npos);
  bytes.replace(at, from.size(), to);
  CHECK_THAT(refusal("jpip.dcm", bytes),
             Catch::Contains("jpip.dcm") && Catch::Contains("transfer syntax"));
}

TEST_CASE("View class from C-arm angles", "[labels][dicom]") {
  // Inside a class's ranges: that class, at distance 0.
  auto m = gimm::view_class_from_angles(gimm::CoronarySystem::LCA, 45, -28);
  CHECK(m.id == 9);  // LCA LAO Caudal
  CHECK(m.distance_deg == 0);
  m = gimm::view_class_from_angles(gimm::CoronarySystem::RCA, 50, 0);
  CHECK(m.id == 2);  // RCA LAO
  // The same pose, the other system: its nearest LCA class.
  m = gimm::view_class_from_angles(gimm::CoronarySystem::LCA, 50, 0);
  CHECK(m.id == 8);  // LAO Cranial, 15 degrees of secondary away
  CHECK(m.distance_deg == Approx(gimm::view_angle_between(50, 0, 50, 15)));
  // Signs: RAO caudal is not LAO caudal.
  CHECK(gimm::view_class_from_angles(gimm::CoronarySystem::LCA, -18, -20).id == 11);
  CHECK(gimm::view_class_from_angles(gimm::CoronarySystem::LCA, 18, -20).id != 11);
  // Without a system, all eleven; a pose far from every class has a large distance.
  m = gimm::view_class_from_angles(std::nullopt, 120, 0);
  CHECK(m.distance_deg > 50);
  CHECK_THROWS_WITH(gimm::view_class_from_angles(std::nullopt, NAN, 0), Catch::Contains("finite"));
}

TEST_CASE("DICOM pair: per-view corrections, exposed fields and view classes", "[io][dicom]") {
  Spec a, b;  // A: AP at table 0; B: LAO 50 at a table moved 20 mm laterally
  a.tags[{0x0018, 0x1510}] = {gdcm::VR::DS, "0"};
  a.tags[{0x0018, 0x1511}] = {gdcm::VR::DS, "0"};
  a.tags[{0x0019, 0x0010}] = {gdcm::VR::LO, "DLX_SERIE_01"};
  a.tags[{0x0019, 0x1021}] = {gdcm::VR::DS, "0"};
  a.tags[{0x0019, 0x1022}] = {gdcm::VR::DS, "0"};
  a.tags[{0x0019, 0x1023}] = {gdcm::VR::DS, "0"};
  b.tags = a.tags;
  b.tags[{0x0018, 0x1510}] = {gdcm::VR::DS, "50"};
  b.tags[{0x0019, 0x1023}] = {gdcm::VR::DS, "20"};
  b.tags[{0x0018, 0x1600}] = {gdcm::VR::CS, "RECTANGULAR"};
  b.tags[{0x0018, 0x1602}] = {gdcm::VR::IS, "2"};
  b.tags[{0x0018, 0x1604}] = {gdcm::VR::IS, "8"};
  b.tags[{0x0018, 0x1606}] = {gdcm::VR::IS, "1"};
  b.tags[{0x0018, 0x1608}] = {gdcm::VR::IS, "6"};
  write_spec(tmp("pair_a.dcm"), a);
  write_spec(tmp("pair_b.dcm"), b);
  const std::string pa = tmp("pair_a.dcm").string(), pb = tmp("pair_b.dcm").string();

  gimm::DicomPairOptions o;
  o.detect_field = false;  // 6 x 8 px: too small to look for a collimator in
  o.system = gimm::CoronarySystem::RCA;
  const gimm::DicomPair plain = gimm::load_dicom_pair(pa, pb, o);
  // B's table is relative to A's: the patient moved +20 mm to its left, B's isocentre -20 in x.
  CHECK(plain.b.frame.carm.view_isocenter() == Eigen::Vector3d(-20, 0, 0));
  CHECK(plain.a.view_class == 1);  // RCA AP Cranial, 15 deg of secondary away: warned of
  REQUIRE(!plain.warnings.empty());
  CHECK_THAT(plain.warnings[0], Catch::Contains("view A: the nearest view class, 1, is 15 deg"));
  CHECK(plain.b.view_class == 2);   // RCA LAO
  CHECK(plain.b.field(0, 0) == 0);  // the shutter's left edge is column 2 (1-based)
  CHECK(plain.b.field(3, 4) == 1);
  CHECK(plain.a.field_source == "whole image (100% of the image)");

  // Correct one view only: B's table and A's pitch.
  o.b.table_mm = Eigen::Vector3d(5, 0, 0);
  o.a.pitch_mm = 0.5;
  const gimm::DicomPair fixed = gimm::load_dicom_pair(pa, pb, o);
  CHECK(fixed.b.frame.carm.view_isocenter() == Eigen::Vector3d(-5, 0, 0));
  CHECK(fixed.a.camera.K()(0, 0) == Approx(1100 / 0.5));
  CHECK(fixed.b.camera.K()(0, 0) == Approx(1100 / 0.2));  // B keeps its file's pitch
  REQUIRE(fixed.b.corrections.size() == 1);
  CHECK_THAT(fixed.b.corrections[0], Catch::Contains("replaced by (5 0 0)"));
  // A whole camera for B, given by hand.
  gimm::CArm by_hand = fixed.b.frame.carm;
  by_hand.primary_deg = 52;
  o.b.camera = by_hand.camera();
  const gimm::DicomPair given = gimm::load_dicom_pair(pa, pb, o);
  CHECK((given.b.camera.P() - by_hand.camera().P()).norm() == 0);
  o.b.camera = gimm::CArm{}.camera();  // 512 x 512: not this frame's
  CHECK_THROWS_WITH(gimm::load_dicom_pair(pa, pb, o),
                    Catch::Contains("view B") && Catch::Contains("512 x 512"));
  o.b.camera.reset();

  // No system: refused where the classes are needed, a reported guess where they are not.
  o.system.reset();
  o.need_system = true;
  CHECK_THROWS_WITH(gimm::load_dicom_pair(pa, pb, o),
                    Catch::Contains("view A") && Catch::Contains("LCA or RCA"));
  o.need_system = false;
  const gimm::DicomPair guessed = gimm::load_dicom_pair(pa, pb, o);
  CHECK_THAT(guessed.a.class_note, Catch::Contains("system not given"));
  // A pose far from every class is warned of.
  b.tags[{0x0018, 0x1510}] = {gdcm::VR::DS, "120"};
  write_spec(tmp("pair_far.dcm"), b);
  o.system = gimm::CoronarySystem::LCA;
  const gimm::DicomPair far = gimm::load_dicom_pair(pa, tmp("pair_far.dcm").string(), o);
  bool warned = false;
  for (const auto& w : far.warnings) warned |= w.find("view B: the nearest view class") == 0;
  CHECK(warned);
}
