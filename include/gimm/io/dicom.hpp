#pragma once
/// X-ray angiography DICOM in and out: one frame of an XA or XRF image, and the C-arm that
/// took it, read from the file's positioner, distance, detector and table tags (GDCM; CMake
/// target gimm::dicom, docs/dicom.md).
///
/// Reading (read_xa_dicom):
/// - Modality XA or RF (or an XA / XRF SOP class); single- or multi-frame; every transfer syntax
///   GDCM decodes (uncompressed, RLE, JPEG lossless, JPEG-LS, JPEG 2000); 8-16 bit, one sample
///   per pixel. The frame is `frame` (0-based), by default the middle one: frames / 2, the frame
///   most likely to show the contrast-filled tree in a run that starts before the injection.
/// - Intensities: MONOCHROME1 is inverted to MONOCHROME2 (vessels dark, as gimm renders them),
///   then the frame's 0.5th-99.5th percentiles are mapped to [0, 1] (clipped), so a 10-bit
///   run stored in 16 bits and an 8-bit one look alike to the matchers.
/// - Orientation: FieldOfViewRotation (0018,7032) and FieldOfViewHorizontalFlip (0018,7034)
///   describe how the stored pixels were turned from the detector (rotate clockwise, then flip);
///   both are undone so the image is in the detector's own orientation, the one CArm projects to.
/// - Geometry: PositionerPrimaryAngle (+LAO), PositionerSecondaryAngle (+cranial),
///   DistanceSourceToDetector (SID), DistanceSourceToPatient (SOD, to the isocentre): required.
///   Pixel pitch at the detector: ImagerPixelSpacing (row\column); without it IntensifierSize /
///   Columns, with a warning; without both, an error (or the caller's pitch_mm). The principal
///   point is the image centre, unless FieldOfViewOrigin, DetectorActiveDimensions and
///   DetectorElementSpacing place the detector's centre in the image.
/// - Table: a vendor block found by its private creator under PS3.5 7.8.1 (the creator at
///   (gggg,00xx) owns (gggg,xx00-xxFF)): GE DL's DLX_SERIE_01 (gggg = 0019, xx21 vertical, xx22
///   longitudinal, xx23 lateral), then GEMS_DL_FRAME_01 (0025, xx1B-xx1D); else the standard
///   TableTop{Vertical,Longitudinal,Lateral}Position (300A,0128-012A). Table-like private tags
///   under another creator are named in a warning. The change between two views moves the
///   patient with the table (CArm, "table"). PatientPosition HFS or FFS; HFS is assumed, with a
///   warning, only when the tag is absent.
/// - Exposed field: the collimator shutters (0018,1600-1622; rectangular, circular, polygonal)
///   as a mask in detector orientation, `field`; without shutter tags the field is found in the
///   image (match/field_of_view.hpp does that for any image).
/// - Every tag looked at is in `tags` with its value or "absent", and what was done with it.
#include <gdcmDataElement.h>
#include <gdcmDataSet.h>
#include <gdcmDict.h>
#include <gdcmDicts.h>
#include <gdcmGlobal.h>
#include <gdcmImage.h>
#include <gdcmImageReader.h>
#include <gdcmImageWriter.h>
#include <gdcmMediaStorage.h>
#include <gdcmStringFilter.h>
#include <gdcmTrace.h>
#include <gdcmTransferSyntax.h>
#include <gdcmUIDGenerator.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/image.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/io/files.hpp"

namespace gimm {

/// One tag the reader looked at: the explain report's line.
struct DicomTagUse {
  std::string tag;    ///< "(0018,1510)"
  std::string name;   ///< "PositionerPrimaryAngle"
  std::string value;  ///< as stored, or "absent"
  std::string use;    ///< what gimm did with it
};

struct DicomReadOptions {
  std::optional<int> frame;        ///< 0-based; default: the middle frame
  std::optional<double> pitch_mm;  ///< detector pixel pitch, overriding the file's tags
};

/// One frame of an X-ray angiogram and its C-arm.
struct XaFrame {
  std::string path;
  Image<float> image;  ///< [0, 1], MONOCHROME2, detector orientation, `carm.rows` x `carm.cols`
  CArm carm;           ///< table_mm read; reference_table_mm = table_mm until set_reference
  int frame = 0;
  int frames = 1;
  /// Where the table came from: "none", "standard (300A,0128-012A)" or "private <creator>
  /// (gggg,00xx), ...: vertical (gggg,xx21), ..." naming the private creator and the tags.
  std::string table_source = "none";
  /// The collimator shutters' exposed field (1 inside), detector orientation; empty when the
  /// file has no shutter tags (match/field_of_view.hpp finds it in the image then).
  Image<std::uint8_t> field;
  std::string field_source = "none";  ///< "shutter RECTANGULAR\\CIRCULAR (0018,1600)", ...
  std::vector<DicomTagUse> tags;
  std::vector<std::string> warnings;
};

/// Makes `reference`'s table position the one whose isocentre is `frame.carm.isocenter`.
inline void set_table_reference(XaFrame& frame, const XaFrame& reference) {
  frame.carm.reference_table_mm = reference.carm.table_mm;
}

namespace detail {

inline void quiet_gdcm() {
  // GDCM prints its own diagnostics to stderr; gimm reports errors itself, naming the file.
  gdcm::Trace::SetWarning(false);
  gdcm::Trace::SetDebug(false);
  gdcm::Trace::SetError(false);
}

/// The largest ratio of decoded to file size gimm accepts for compressed pixels: lossless
/// coronary cine compresses about 2-4:1, and a forged header must not make gimm allocate
/// gigabytes for a small file (docs/dev/fuzzing.md).
inline constexpr std::uint64_t kMaxDicomCompression = 256;

inline std::string tag_string(std::uint16_t group, std::uint16_t element) {
  char text[16];
  std::snprintf(text, sizeof text, "(%04X,%04X)", group, element);
  return text;
}

/// Little-endian bytes of a file, read at an offset into a small window.
class DicomBytes {
 public:
  explicit DicomBytes(const std::string& path)
      : size(file_size_of(path)), in_(path, std::ios::binary) {
    GIMM_CHECK_AS(IoError, in_, path << ": cannot open");
  }
  /// Reads `n` (<= 12) bytes at `at` into the window; false if the file ends first.
  bool read_at(std::uint64_t at, std::size_t n) {
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(at));
    in_.read(reinterpret_cast<char*>(b_), static_cast<std::streamsize>(n));
    return static_cast<std::size_t>(in_.gcount()) == n;
  }
  std::uint8_t u8(int i) const { return b_[i]; }
  std::uint16_t u16(int i) const { return std::uint16_t(b_[i] | b_[i + 1] << 8); }
  std::uint32_t u32(int i) const { return std::uint32_t(u16(i)) | std::uint32_t(u16(i + 2)) << 16; }
  std::string text(int i, int n) const {
    return std::string(reinterpret_cast<const char*>(b_ + i), n);
  }
  /// `n` bytes at `at` as text, trailing blanks and NULs removed.
  std::string value_at(std::uint64_t at, std::size_t n) {
    std::string value(n, '\0');
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(at));
    in_.read(value.data(), static_cast<std::streamsize>(n));
    return value.substr(0, value.find_last_not_of(std::string(" \0", 2)) + 1);
  }
  const std::uint64_t size;

 private:
  std::ifstream in_;
  unsigned char b_[12];
};

/// One element's header: its tag, VR ("implicit" when none is written), value length (bytes;
/// 0xFFFFFFFF is undefined) and where its value starts.
struct DicomElementHeader {
  std::uint16_t group = 0, element = 0;
  std::string vr = "implicit";
  std::uint64_t length = 0, value_at = 0;
  std::string tag() const { return tag_string(group, element); }
};

/// The header of the element at byte `at`, in implicit or explicit VR little endian. An element
/// whose VR bytes are not two capitals is read as implicit, as GDCM reads it (it accepts files
/// that mix implicit into explicit VR); two capitals that are not one of DICOM's VRs are refused.
inline DicomElementHeader read_element_header(DicomBytes& bytes, std::uint64_t at, bool implicit,
                                              const std::string& path) {
  DicomElementHeader h;
  GIMM_CHECK_AS(FormatError, bytes.read_at(at, 8),
                path << ": element header cut off at byte " << at);
  h.group = bytes.u16(0);
  h.element = bytes.u16(2);
  h.value_at = at + 8;
  const bool letters = std::isupper(bytes.u8(4)) && std::isupper(bytes.u8(5));
  if (implicit || !letters) {
    h.length = bytes.u32(4);
    return h;
  }
  h.vr = bytes.text(4, 2);
  // The VRs of PS3.5 6.2; the second row has a 4-byte length (after 2 reserved bytes).
  static const std::string short_form =
      "AE AS AT CS DA DS DT FL FD IS LO LT PN SH SL SS ST TM UI UL US";
  static const std::string long_form = "OB OD OF OL OV OW SQ SV UC UN UR UT UV";
  const auto is_vr = [&](const std::string& list) {
    const auto found = list.find(h.vr);
    return found != std::string::npos && found % 3 == 0;
  };
  GIMM_CHECK_AS(FormatError, is_vr(short_form) || is_vr(long_form),
                path << ": element " << h.tag() << " at byte " << at << " has VR '" << h.vr
                     << "', which is not a DICOM VR");
  if (is_vr(long_form)) {
    GIMM_CHECK_AS(FormatError, bytes.read_at(at, 12),
                  path << ": element " << h.tag() << " is cut off at byte " << at);
    h.length = bytes.u32(8);
    h.value_at = at + 12;
  } else {
    h.length = bytes.u16(6);
  }
  return h;
}

/// The file meta group's own rule: (0002,0000), its group length, leaves room for a data set.
inline void check_meta_group_length(DicomBytes& bytes, const DicomElementHeader& h,
                                    const std::string& path) {
  if (h.element != 0x0000 || h.length != 4 || !bytes.read_at(h.value_at, 4)) return;
  const std::uint64_t group_end = h.value_at + 4 + bytes.u32(0);
  GIMM_CHECK_AS(FormatError, group_end < bytes.size,
                path << ": the file meta group length (0002,0000) = " << bytes.u32(0)
                     << " ends at byte " << group_end << ", but the file has " << bytes.size
                     << " bytes and needs a data set after it");
}

/// `s` without leading and trailing blanks (DICOM pads values to an even length).
inline std::string trimmed(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t\r\n") - first + 1);
}

/// The image pixel module's one-number attributes (PS3.3 C.7.6.3), which GDCM reads as one US
/// and asserts on when their length is another: samples per pixel, planar configuration,
/// rows, columns, bits allocated and stored, high bit, pixel representation.
inline bool is_image_pixel_us(const DicomElementHeader& h) {
  if (h.group != 0x0028) return false;
  for (const std::uint16_t e : {0x0002, 0x0006, 0x0010, 0x0011, 0x0100, 0x0101, 0x0102, 0x0103})
    if (h.element == e) return true;
  return false;
}

/// Values GDCM checks with assertions: the image pixel module's VR and length (above) and
/// NumberOfFrames' (IS),
/// SamplesPerPixel (it asserts <= 4; gimm reads 1) and the retired ACR-NEMA RecognitionCode
/// (0008,0010) (it asserts the value starts "ACR-NEMA").
inline void check_element_value(DicomBytes& bytes, const DicomElementHeader& h,
                                const std::string& path) {
  // GDCM reads the image's geometry and pixel description (groups 0018, 0020, 0028) through
  // gdcm::Attribute, which asserts that an element's VR is compatible with its dictionary VR
  // (libFuzzer: FrameIncrementPointer (0028,0009) under another VR). UN is left to GDCM.
  if (h.vr != "implicit" && (h.group == 0x0018 || h.group == 0x0020 || h.group == 0x0028)) {
    const gdcm::VR expected =
        gdcm::Global::GetInstance().GetDicts().GetDictEntry(gdcm::Tag(h.group, h.element)).GetVR();
    const gdcm::VR found = gdcm::VR::GetVRType(h.vr.c_str());
    if (expected != gdcm::VR::INVALID && found != gdcm::VR::UN)
      GIMM_CHECK_AS(FormatError, expected.Compatible(found),
                    path << ": element " << h.tag() << " has VR " << h.vr
                         << " where the DICOM dictionary says " << expected);
  }
  if (is_image_pixel_us(h))  // the VR is checked above, against the dictionary
    GIMM_CHECK_AS(FormatError, h.length == 2,
                  path << ": element " << h.tag() << " has " << h.length
                       << " bytes; an image pixel attribute is one US (2 bytes)");
  // The SOP class, from the file meta group or the data set: GDCM picks its reading path by it
  // and asserts when a known class is not an image (libFuzzer: a presentation state's UID).
  if ((h.group == 0x0002 && h.element == 0x0002) || (h.group == 0x0008 && h.element == 0x0016)) {
    std::string uid = bytes.value_at(h.value_at, std::min<std::uint64_t>(h.length, 64));
    while (!uid.empty() && (uid.back() == '\0' || uid.back() == ' ')) uid.pop_back();
    const auto storage = gdcm::MediaStorage::GetMSType(uid.c_str());
    GIMM_CHECK_AS(FormatError,
                  storage != gdcm::MediaStorage::MS_END && gdcm::MediaStorage::IsImage(storage),
                  path << ": element " << h.tag() << " SOP class '" << uid
                       << "' is not an image storage class (X-ray angiography is "
                          "1.2.840.10008.5.1.4.1.1.12.1)");
  }
  if (h.group == 0x0028 && h.element == 0x0008) {  // NumberOfFrames, read by the same GDCM code
    GIMM_CHECK_AS(FormatError, (h.vr == "IS" || h.vr == "implicit") && h.length <= 12,
                  path << ": element (0028,0008) NumberOfFrames has VR " << h.vr << " and "
                       << h.length << " bytes; it is one IS (at most 12 bytes)");
    // GDCM reads "abc" as 1 frame and a run of 3 frames then shows only the first.
    const std::string frames = trimmed(bytes.value_at(h.value_at, h.length));
    GIMM_CHECK_AS(FormatError,
                  !frames.empty() && frames.size() <= 9 &&
                      std::all_of(frames.begin(), frames.end(),
                                  [](unsigned char c) { return std::isdigit(c); }) &&
                      std::stol(frames) >= 1,
                  path << ": (0028,0008) NumberOfFrames is '" << frames
                       << "', not a whole number of frames >= 1");
  }
  // PhotometricInterpretation: GDCM asserts on a PALETTE COLOR image without its lookup tables,
  // which aborts the process; an angiogram is grey-scale, so anything else is refused here.
  if (h.group == 0x0028 && h.element == 0x0004) {
    const std::string pi =
        trimmed(bytes.value_at(h.value_at, std::min<std::uint64_t>(h.length, 64)));
    GIMM_CHECK_AS(FormatError, pi == "MONOCHROME1" || pi == "MONOCHROME2",
                  path << ": (0028,0004) PhotometricInterpretation is '" << pi
                       << "'; an X-ray angiogram is MONOCHROME1 or MONOCHROME2");
  }
  if (h.group == 0x0008 && h.element == 0x0010) {
    const std::string code = bytes.value_at(h.value_at, std::min<std::uint64_t>(h.length, 8));
    GIMM_CHECK_AS(FormatError, code == "ACR-NEMA",
                  path << ": (0008,0010) RecognitionCode (a retired ACR-NEMA element) is '" << code
                       << "...', not 'ACR-NEMA...'");
  }
  if (h.group == 0x0028 && h.element == 0x0002 && h.length == 2 && bytes.read_at(h.value_at, 2))
    GIMM_CHECK_AS(FormatError, bytes.u16(0) == 1,
                  path << ": (0028,0002) SamplesPerPixel is " << bytes.u16(0)
                       << ": gimm reads grey-scale frames (1 sample per pixel)");
}

constexpr std::uint32_t kUndefinedLength = 0xFFFFFFFFu;
constexpr int kMaxSequenceDepth = 16;

inline std::uint64_t walk_items(DicomBytes& bytes, std::uint64_t at, std::uint64_t end,
                                bool delimited, bool implicit, bool fragments, int depth,
                                const std::string& path);

/// Walks the elements of a data set from byte `at`: up to `end` (the file, or a defined-length
/// item), or, when `delimited`, up to its item delimiter (FFFE,E00D). Returns the byte after it.
/// Refuses, naming the element and the byte: a value past `end`, VR bytes that are not a VR in
/// explicit VR, tags out of order, a tail too short for an element, and the values of
/// check_element_value. Sequences and encapsulated pixels are walked through walk_items.
inline std::uint64_t walk_data_set(DicomBytes& bytes, std::uint64_t at, std::uint64_t end,
                                   bool delimited, bool implicit, int depth,
                                   const std::string& path) {
  std::uint32_t previous_tag = 0;  // tags ascend (PS3.5 7.1)
  std::string previous = "the item header";
  for (;;) {
    if (!delimited && at == end) return at;
    GIMM_CHECK_AS(FormatError, at + 8 <= end && bytes.read_at(at, 8),
                  path << ": " << end - at << " bytes after element " << previous
                       << " at the end of " << (end == bytes.size ? "the file" : "an item")
                       << ": too few for another element");
    if (bytes.u16(0) == 0xFFFE) {
      GIMM_CHECK_AS(FormatError, delimited && bytes.u16(2) == 0xE00D,
                    path << ": item tag " << tag_string(0xFFFE, bytes.u16(2)) << " at byte " << at
                         << " where a data element is expected");
      return at + 8;
    }
    const DicomElementHeader h = read_element_header(bytes, at, implicit, path);
    // Mixed implicit VR inside explicit VR, and tags out of order, send GDCM guessing (asserts
    // and gigabyte allocations, found by libFuzzer); a conforming file has neither.
    GIMM_CHECK_AS(FormatError, implicit || h.vr != "implicit",
                  path << ": element " << h.tag() << " at byte " << at
                       << " has no VR in an explicit VR data set");
    const std::uint32_t tag = std::uint32_t(h.group) << 16 | h.element;
    GIMM_CHECK_AS(FormatError, tag > previous_tag,
                  path << ": element " << h.tag() << " at byte " << at << " follows " << previous
                       << ": data set elements must ascend by tag");
    previous_tag = tag;
    previous = h.tag();
    if (h.length == kUndefinedLength) {
      const bool pixels = tag == 0x7FE00010u && (h.vr == "OB" || h.vr == "OW");
      GIMM_CHECK_AS(FormatError, pixels || h.vr == "SQ" || h.vr == "UN" || h.vr == "implicit",
                    path << ": element " << h.tag() << " (VR " << h.vr << ") at byte " << at
                         << " has an undefined length, which only sequences and encapsulated "
                            "pixel data may have");
      // A UN sequence is implicit VR inside (PS3.5 6.2.2).
      at = walk_items(bytes, h.value_at, end, true, implicit || h.vr == "UN", pixels, depth + 1,
                      path);
      continue;
    }
    GIMM_CHECK_AS(FormatError, h.value_at + h.length <= end,
                  path << ": element " << h.tag() << " (VR " << h.vr << ") at byte " << at
                       << " claims " << h.length << " bytes, past the end of the "
                       << (end == bytes.size ? std::to_string(end) + "-byte file" : "item"));
    if (h.vr == "SQ")
      walk_items(bytes, h.value_at, h.value_at + h.length, false, implicit, false, depth + 1, path);
    check_element_value(bytes, h, path);
    at = h.value_at + h.length;
  }
}

/// Walks the items of a sequence (or the fragments of encapsulated pixel data) from byte `at`:
/// up to `end`, or, when `delimited`, up to the sequence delimiter (FFFE,E0DD). Returns the byte
/// after it. Items of undefined length end at their item delimiter; fragments have a length.
inline std::uint64_t walk_items(DicomBytes& bytes, std::uint64_t at, std::uint64_t end,
                                bool delimited, bool implicit, bool fragments, int depth,
                                const std::string& path) {
  GIMM_CHECK_AS(
      FormatError, depth <= kMaxSequenceDepth,
      path << ": sequences nested deeper than " << kMaxSequenceDepth << " at byte " << at);
  for (;;) {
    if (!delimited && at == end) return at;
    GIMM_CHECK_AS(FormatError, at + 8 <= end && bytes.read_at(at, 8),
                  path << ": a sequence is cut off at byte " << at);
    const std::uint16_t group = bytes.u16(0), element = bytes.u16(2);
    const std::uint32_t length = bytes.u32(4);
    if (delimited && group == 0xFFFE && element == 0xE0DD) return at + 8;
    GIMM_CHECK_AS(FormatError, group == 0xFFFE && element == 0xE000,
                  path << ": " << tag_string(group, element) << " at byte " << at
                       << " inside a sequence, where an item (FFFE,E000) is expected");
    if (length == kUndefinedLength) {
      GIMM_CHECK_AS(FormatError, !fragments,
                    path << ": pixel data fragment at byte " << at << " has an undefined length");
      at = walk_data_set(bytes, at + 8, end, true, implicit, depth, path);
      continue;
    }
    GIMM_CHECK_AS(FormatError, at + 8 + length <= end,
                  path << ": item at byte " << at << " claims " << length
                       << " bytes, past the end of its sequence or the file");
    if (!fragments) walk_data_set(bytes, at + 8, at + 8 + length, false, implicit, depth, path);
    at += 8 + length;
  }
}

/// Walks a DICOM Part 10 file before GDCM reads it (the file meta group, then the data set in
/// explicit or implicit VR little endian, into its sequences and encapsulated pixels), and
/// refuses what would make GDCM abort or allocate what the file cannot hold: see
/// walk_data_set. Why: Debian's GDCM is built with assertions, and such files abort the process
/// inside GDCM instead of failing (docs/dev/fuzzing.md). Stricter than GDCM where GDCM guesses:
/// the file meta group must follow "DICM", be explicit VR with defined lengths and name a
/// known transfer syntax that is not the retired big endian one; the data set must not mix
/// implicit into explicit VR, and its tags must ascend; files without the Part 10 "DICM" prefix
/// are refused. Only a deflated data set is left to GDCM.
inline void check_top_level_elements(const std::string& path) {
  DicomBytes bytes(path);
  const std::uint64_t size = bytes.size;
  // Without the prefix GDCM guesses an ACR-NEMA or raw data set (libFuzzer: 18 s and 1.6 GB on
  // a 295-byte file); angiography systems write Part 10 files.
  GIMM_CHECK_AS(FormatError, size >= 132 && bytes.read_at(128, 4) && bytes.text(0, 4) == "DICM",
                path << ": not a DICOM file: no \"DICM\" prefix at byte 128 (gimm reads DICOM "
                        "Part 10 files)");
  GIMM_CHECK_AS(FormatError, bytes.read_at(132, 2) && bytes.u16(0) == 0x0002,
                path << ": no file meta group (0002,xxxx) after the \"DICM\" prefix at byte 132");
  std::string syntax;  // (0002,0010)
  bool has_syntax = false;
  std::uint64_t at = 132;
  while (bytes.read_at(at, 8) && bytes.u16(0) == 0x0002) {
    const DicomElementHeader h = read_element_header(bytes, at, false, path);
    // PS3.10 7.1: explicit VR little endian (GDCM's reading of an implicit one asserts).
    GIMM_CHECK_AS(FormatError, h.vr != "implicit",
                  path << ": file meta element " << h.tag() << " at byte " << at
                       << " has no VR: the file meta group must be explicit VR");
    GIMM_CHECK_AS(FormatError, h.length != kUndefinedLength,
                  path << ": file meta element " << h.tag() << " at byte " << at
                       << " has an undefined length, which the file meta group cannot have");
    GIMM_CHECK_AS(FormatError, h.value_at + h.length <= size,
                  path << ": element " << h.tag() << " (VR " << h.vr << ") at byte " << at
                       << " claims " << h.length << " bytes, past the end of the " << size
                       << "-byte file");
    check_meta_group_length(bytes, h, path);
    check_element_value(bytes, h, path);
    if (h.element == 0x0010 && h.length < 256) {
      syntax = bytes.value_at(h.value_at, h.length);
      has_syntax = true;
    }
    at = h.value_at + h.length;
    GIMM_CHECK_AS(FormatError, at + 8 <= size,
                  path << ": the file ends inside the file meta group (after " << h.tag()
                       << "): no data set");
  }
  GIMM_CHECK_AS(FormatError, has_syntax,
                path << ": the file meta group has no (0002,0010) TransferSyntaxUID");
  // An unknown UID or big endian sends GDCM guessing (libFuzzer: a 2.9 GB allocation).
  const auto ts = gdcm::TransferSyntax::GetTSType(syntax.c_str());
  GIMM_CHECK_AS(FormatError, ts != gdcm::TransferSyntax::TS_END,
                path << ": unknown transfer syntax (0002,0010) '" << syntax << "'");
  GIMM_CHECK_AS(FormatError, ts != gdcm::TransferSyntax::ExplicitVRBigEndian,
                path << ": transfer syntax " << syntax
                     << " (explicit VR big endian) is retired; gimm does not read it");
  if (ts == gdcm::TransferSyntax::DeflatedExplicitVRLittleEndian) return;  // GDCM inflates
  walk_data_set(bytes, at, size, false, ts == gdcm::TransferSyntax::ImplicitVRLittleEndian, 0,
                path);
}

/// The tags of one data set, read as text, each lookup recorded for the explain report.
class TagReader {
 public:
  TagReader(const gdcm::File& file, std::string path) : file_(file), path_(std::move(path)) {
    filter_.SetFile(file_);
  }

  /// The tag's text value (trimmed), or nullopt; recorded with `use` (or "absent: ...").
  std::optional<std::string> text(std::uint16_t group, std::uint16_t element,
                                  const std::string& name, const std::string& use,
                                  const std::string& when_absent) {
    const gdcm::Tag tag(group, element);
    const gdcm::DataSet& ds = file_.GetDataSet();
    std::optional<std::string> value;
    if (ds.FindDataElement(tag) && !ds.GetDataElement(tag).IsEmpty()) {
      std::string s = element_text(ds.GetDataElement(tag));
      const auto first = s.find_first_not_of(" \t\r\n");
      if (first != std::string::npos)
        value = s.substr(first, s.find_last_not_of(" \t\r\n") - first + 1);
    }
    uses.push_back(
        {tag_string(group, element), name, value ? *value : "absent", value ? use : when_absent});
    return value;
  }

  /// The tag's numbers (DS/IS multi-values separated by '\'); `count` of them when given.
  std::optional<std::vector<double>> numbers(std::uint16_t group, std::uint16_t element,
                                             const std::string& name, const std::string& use,
                                             const std::string& when_absent, int count) {
    const auto value = text(group, element, name, use, when_absent);
    if (!value) return std::nullopt;
    std::vector<double> out;
    std::stringstream in(*value);
    std::string item;
    while (std::getline(in, item, '\\')) {
      char* end = nullptr;
      const double x = std::strtod(item.c_str(), &end);
      while (*end == ' ') ++end;
      GIMM_CHECK(end != item.c_str() && *end == '\0' && std::isfinite(x),
                 path_ << ": tag " << tag_string(group, element) << " " << name
                       << " is not a finite number: '" << *value << "'");
      out.push_back(x);
    }
    GIMM_CHECK(count <= 0 || int(out.size()) == count,
               path_ << ": tag " << tag_string(group, element) << " " << name << " must hold "
                     << count << " numbers, got '" << *value << "'");
    return out;
  }

  /// A number that must be present: an error naming the tag otherwise.
  double required(std::uint16_t group, std::uint16_t element, const std::string& name,
                  const std::string& use) {
    const auto v = numbers(group, element, name, use, "absent: required", 1);
    GIMM_CHECK(v, path_ << ": required tag " << tag_string(group, element) << " " << name
                        << " is missing (" << use << ")");
    return v->front();
  }

  /// The text of an element without recording it (private creators, table-like tags).
  std::optional<std::string> peek(const gdcm::Tag& tag) const {
    const gdcm::DataSet& ds = file_.GetDataSet();
    if (!ds.FindDataElement(tag) || ds.GetDataElement(tag).IsEmpty()) return std::nullopt;
    const std::string s = trimmed(element_text(ds.GetDataElement(tag)));
    if (s.empty()) return std::nullopt;
    return s;
  }

  const gdcm::DataSet& data_set() const { return file_.GetDataSet(); }

  std::vector<DicomTagUse> uses;

 private:
  /// Text of an element. Public tags go through GDCM's string filter, which knows their VR
  /// from the dictionary (an implicit-VR file stores none). Private tags of an implicit-VR
  /// file have no VR: their bytes are taken as text when printable, else as a little-endian
  /// 4-byte integer or 8-byte double.
  std::string element_text(const gdcm::DataElement& de) const {
    const gdcm::VR vr = de.GetVR();
    const bool known_vr = vr != gdcm::VR::UN && vr != gdcm::VR::INVALID;
    if (known_vr || !de.GetTag().IsPrivate()) return filter_.ToString(de.GetTag());
    const gdcm::ByteValue* bytes = de.GetByteValue();
    if (!bytes) return {};
    const std::string raw(bytes->GetPointer(), bytes->GetLength());
    const bool printable = std::all_of(raw.begin(), raw.end(),
                                       [](char c) { return (c >= 0x20 && c < 0x7f) || c == '\0'; });
    if (printable) return std::string(raw.c_str());
    if (raw.size() == 4) {
      std::int32_t v;
      std::memcpy(&v, raw.data(), 4);
      return std::to_string(v);
    }
    if (raw.size() == 8) {
      double v;
      std::memcpy(&v, raw.data(), 8);
      std::ostringstream os;
      os.precision(17);
      os << v;
      return os.str();
    }
    return {};
  }

  const gdcm::File& file_;
  std::string path_;
  gdcm::StringFilter filter_;
};

/// A vendor's private table-position tags: the private creator that owns them, their group and
/// their element offsets within the block the creator reserves (PS3.5 7.8.1).
struct PrivateTableTags {
  const char* creator;
  std::uint16_t group;
  std::uint8_t vertical, longitudinal, lateral;
  const char* note;
};

/// The creators gimm reads the table from, in order of preference. The offsets are those of
/// GDCM's private dictionary; DLX_SERIE_01's were checked on real GE DL (Innova) files, whose
/// (0019,0010) is DLX_SERIE_01 while GEMS_DL_IMG_01 at (0019,0011) owns (0019,11xx).
inline constexpr PrivateTableTags kKnownTableCreators[] = {
    {"DLX_SERIE_01", 0x0019, 0x21, 0x22, 0x23, "GE DL series block (verified on real files)"},
    {"GEMS_DL_FRAME_01", 0x0025, 0x1B, 0x1C, 0x1D, "GE DL frame block (GDCM's dictionary)"},
};

/// PS3.5 7.8.1: a private creator element (gggg,00xx), xx in 10-FF, reserves the elements
/// (gggg,xx00-xxFF) for its owner. Returns xx for `creator` in odd `group`, or nullopt. The
/// creator's value is compared whole (blanks trimmed), not by prefix.
inline std::optional<std::uint8_t> private_block(const TagReader& tags, std::uint16_t group,
                                                 const std::string& creator) {
  for (int xx = 0x10; xx <= 0xFF; ++xx) {
    const auto value = tags.peek(gdcm::Tag(group, std::uint16_t(xx)));
    if (value && *value == creator) return std::uint8_t(xx);
  }
  return std::nullopt;
}

/// The table's (lateral, vertical, longitudinal) tags as read, where they came from, and the
/// warnings about table-like tags that were not used.
struct TableRead {
  std::optional<std::vector<double>> values[3];  // lateral, vertical, longitudinal
  std::string source = "none";
  std::vector<std::string> warnings;
};

inline bool has_table_word(std::string name) {
  std::transform(name.begin(), name.end(), name.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return name.find("table") != std::string::npos &&
         (name.find("vertical") != std::string::npos ||
          name.find("longitudinal") != std::string::npos ||
          name.find("lateral") != std::string::npos || name.find("position") != std::string::npos);
}

/// Whether GDCM's private dictionary knows any element of `creator` in `group`.
inline bool creator_in_dictionary(std::uint16_t group, const std::string& creator) {
  const gdcm::PrivateDict& dict = gdcm::Global::GetInstance().GetDicts().GetPrivateDict();
  for (int offset = 0x00; offset <= 0xFF; ++offset) {
    const char* name =
        dict.GetDictEntry(gdcm::PrivateTag(group, std::uint16_t(offset), creator.c_str()))
            .GetName();
    if (name && *name) return true;
  }
  return false;
}

/// Private elements that look like a table position and were not read: named in a warning, so a
/// table under a creator gimm does not know is not dropped without a word. "Looks like": GDCM's
/// private dictionary names it a table position, or its creator is unknown to the dictionary and
/// it sits at a known table offset of a known table group.
inline void warn_unused_table_tags(const TagReader& tags, const gdcm::DataSet& ds,
                                   const std::string& used_creator, std::vector<std::string>& out) {
  const gdcm::Dicts& dicts = gdcm::Global::GetInstance().GetDicts();
  // Whether each (group, creator) is in the dictionary: asked once per block, not per element
  // (a vendor file has hundreds of private elements, each answer 256 lookups).
  std::map<std::pair<std::uint16_t, std::string>, bool> known_creator;
  for (const gdcm::DataElement& de : ds.GetDES()) {
    const gdcm::Tag tag = de.GetTag();
    const std::uint16_t group = tag.GetGroup(), element = tag.GetElement();
    if (group % 2 == 0 || element < 0x1000) continue;  // public, or a creator itself
    const auto creator = tags.peek(gdcm::Tag(group, std::uint16_t(element >> 8)));
    if (!creator || *creator == used_creator) continue;
    const std::uint8_t offset = std::uint8_t(element & 0xFF);
    const gdcm::DictEntry& entry =
        dicts.GetPrivateDict().GetDictEntry(gdcm::PrivateTag(group, offset, creator->c_str()));
    const std::string name = entry.GetName() ? entry.GetName() : "";
    bool table_like = !name.empty() && has_table_word(name);
    const auto block = known_creator.try_emplace({group, *creator}, false);
    if (block.second) block.first->second = creator_in_dictionary(group, *creator);
    if (name.empty() && !block.first->second)
      for (const auto& known : kKnownTableCreators)
        table_like |=
            group == known.group &&
            (offset == known.vertical || offset == known.longitudinal || offset == known.lateral);
    if (!table_like) continue;
    const auto value = tags.peek(tag);
    out.push_back(tag_string(group, element) + " = " + (value ? *value : "(empty)") +
                  " under private creator '" + *creator + "'" +
                  (name.empty() ? " (unknown to gimm) sits where GE writes a table position"
                                : " is '" + name + "'") +
                  ": not used for the table" +
                  (used_creator.empty() ? "; give the table by hand if it is one" : ""));
  }
}

/// The table position: a known vendor block (kKnownTableCreators) found by the PS3.5 rule, else
/// the standard TableTop{Vertical,Longitudinal,Lateral}Position (300A,0128-012A).
inline TableRead read_table(TagReader& tags) {
  TableRead out;
  std::string used_creator;
  for (const auto& known : kKnownTableCreators) {
    const auto block = private_block(tags, known.group, known.creator);
    if (!block) continue;
    const auto element = [&](std::uint8_t offset) {
      return std::uint16_t(std::uint16_t(*block) << 8 | offset);
    };
    const std::string who =
        std::string(known.creator) + " " + tag_string(known.group, *block) + ", " + known.note;
    const std::string use = "table position, mm (" + who + ")";
    tags.uses.push_back({tag_string(known.group, *block), "PrivateCreator", known.creator,
                         "owns " + tag_string(known.group, element(0)).substr(0, 8) +
                             "xx) (PS3.5 7.8.1): the table is read there"});
    out.values[1] = tags.numbers(known.group, element(known.vertical), "TableVerticalPosition", use,
                                 "absent", 1);
    out.values[2] = tags.numbers(known.group, element(known.longitudinal),
                                 "TableLongitudinalPosition", use, "absent", 1);
    out.values[0] =
        tags.numbers(known.group, element(known.lateral), "TableLateralPosition", use, "absent", 1);
    if (out.values[0] || out.values[1] || out.values[2]) {
      out.source = "private " + who + ": vertical " +
                   tag_string(known.group, element(known.vertical)) + ", longitudinal " +
                   tag_string(known.group, element(known.longitudinal)) + ", lateral " +
                   tag_string(known.group, element(known.lateral));
      used_creator = known.creator;
      break;
    }
  }
  if (used_creator.empty()) {
    out.values[1] =
        tags.numbers(0x300A, 0x0128, "TableTopVerticalPosition", "table position, mm", "absent", 1);
    out.values[2] = tags.numbers(0x300A, 0x0129, "TableTopLongitudinalPosition",
                                 "table position, mm", "absent", 1);
    out.values[0] =
        tags.numbers(0x300A, 0x012A, "TableTopLateralPosition", "table position, mm", "absent", 1);
    if (out.values[0] || out.values[1] || out.values[2]) out.source = "standard (300A,0128-012A)";
  }
  warn_unused_table_tags(tags, tags.data_set(), used_creator, out.warnings);
  return out;
}

/// Whether stored pixel (row r, column c), 0-based, is inside the polygon of 1-based (row,
/// column) vertices (DICOM's pixel coordinates: the first pixel is 1\1).
inline bool inside_polygon(const std::vector<double>& rc, double r, double c) {
  bool inside = false;
  const std::size_t n = rc.size() / 2;
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
    const double ri = rc[2 * i] - 1, ci = rc[2 * i + 1] - 1, rj = rc[2 * j] - 1,
                 cj = rc[2 * j + 1] - 1;
    if ((ri > r) != (rj > r) && c < (cj - ci) * (r - ri) / (rj - ri) + ci) inside = !inside;
  }
  return inside;
}

/// The Display Shutter module (PS3.3 C.7.6.11): the exposed field in stored orientation, 1
/// inside every shutter the file names (they intersect), or nullopt when there is none.
/// Coordinates are 1-based pixel rows and columns; edges are inside.
inline std::optional<Image<float>> shutter_field(TagReader& tags, int rows, int cols,
                                                 const std::string& path, std::string& source,
                                                 std::vector<std::string>& warnings) {
  const auto shape = tags.text(0x0018, 0x1600, "ShutterShape", "the exposed field", "absent");
  if (!shape) return std::nullopt;
  Image<float> field(rows, cols, 1.0f);
  std::stringstream in(*shape);
  std::string one;
  const auto need = [&](std::uint16_t e, const char* name, int count) {
    const auto v = tags.numbers(0x0018, e, name, "shutter, 1-based px", "absent", count);
    GIMM_CHECK(v, path << ": (0018,1600) ShutterShape names " << one << " but " << name << " "
                       << tag_string(0x0018, e) << " is absent");
    return *v;
  };
  while (std::getline(in, one, '\\')) {
    one = trimmed(one);
    if (one == "RECTANGULAR") {
      const double left = need(0x1602, "ShutterLeftVerticalEdge", 1)[0];
      const double right = need(0x1604, "ShutterRightVerticalEdge", 1)[0];
      const double upper = need(0x1606, "ShutterUpperHorizontalEdge", 1)[0];
      const double lower = need(0x1608, "ShutterLowerHorizontalEdge", 1)[0];
      GIMM_CHECK(left < right && upper < lower, path << ": rectangular shutter with left " << left
                                                     << ", right " << right << ", upper " << upper
                                                     << ", lower " << lower
                                                     << ": left must be < right and upper < lower");
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c)
          if (c + 1 < left || c + 1 > right || r + 1 < upper || r + 1 > lower) field(r, c) = 0;
    } else if (one == "CIRCULAR") {
      const auto centre = need(0x1610, "CenterOfCircularShutter", 2);  // row \ column
      const double radius = need(0x1612, "RadiusOfCircularShutter", 1)[0];
      GIMM_CHECK(radius > 0,
                 path << ": (0018,1612) RadiusOfCircularShutter must be > 0, got " << radius);
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c)
          if (std::hypot(r + 1 - centre[0], c + 1 - centre[1]) > radius) field(r, c) = 0;
    } else if (one == "POLYGONAL") {
      const auto v = need(0x1620, "VerticesOfThePolygonalShutter", 0);
      GIMM_CHECK(v.size() >= 6 && v.size() % 2 == 0,
                 path << ": (0018,1620) VerticesOfThePolygonalShutter holds " << v.size()
                      << " numbers; at least 3 row\\column pairs expected");
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c)
          if (!inside_polygon(v, r, c)) field(r, c) = 0;
    } else if (one == "BITMAP") {
      warnings.push_back(
          "(0018,1600) ShutterShape BITMAP (an overlay plane) is not read: that "
          "shutter is left out of the field (the image-based field still applies)");
    } else {
      GIMM_FAIL(path << ": (0018,1600) ShutterShape '" << one
                     << "' is not RECTANGULAR, CIRCULAR, POLYGONAL or BITMAP");
    }
  }
  source = "shutter " + *shape + " (0018,1600)";
  return field;
}

/// Undoes FieldOfViewRotation (clockwise, degrees) and then the horizontal flip applied after
/// it: stored = flip(rotate_cw(detector)), so detector = rotate_ccw(flip(stored)).
inline Image<float> to_detector_orientation(const Image<float>& stored, int rotation_deg,
                                            bool flipped) {
  Image<float> unflipped = stored;
  if (flipped)
    for (int r = 0; r < stored.rows(); ++r)
      for (int c = 0; c < stored.cols(); ++c) unflipped(r, c) = stored(r, stored.cols() - 1 - c);
  const int quarter_turns = (rotation_deg / 90) % 4;
  Image<float> out = unflipped;
  for (int q = 0; q < quarter_turns; ++q) {  // one counter-clockwise quarter turn each
    Image<float> turned(out.cols(), out.rows());
    for (int r = 0; r < out.rows(); ++r)
      for (int c = 0; c < out.cols(); ++c) turned(out.cols() - 1 - c, r) = out(r, c);
    out = std::move(turned);
  }
  return out;
}

/// The frame's stored values -> [0, 1] by its 0.5th and 99.5th percentiles.
inline Image<float> percentile_window(const std::vector<double>& values, int rows, int cols) {
  std::vector<double> sorted = values;
  const auto at = [&](double q) {
    const std::size_t k = std::min(sorted.size() - 1, std::size_t(q * double(sorted.size() - 1)));
    std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(k), sorted.end());
    return sorted[k];
  };
  const double lo = at(0.005), hi = at(0.995);
  const double span = hi > lo ? hi - lo : 1.0;
  Image<float> out(rows, cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c)
      out(r, c) = float(std::clamp((values[std::size_t(r) * cols + c] - lo) / span, 0.0, 1.0));
  return out;
}

}  // namespace detail

/// Reads one frame of an XA/XRF DICOM file and its C-arm. Throws gimm::Error naming the file
/// and the tag or value at fault.
inline XaFrame read_xa_dicom(const std::string& path, const DicomReadOptions& options = {}) {
  detail::quiet_gdcm();
  GIMM_CHECK_AS(IoError, std::filesystem::is_regular_file(path), path << ": no such file");
  detail::check_top_level_elements(path);
  gdcm::ImageReader reader;
  reader.SetFileName(path.c_str());
  if (!reader.Read()) {
    // Tell "not DICOM" from "DICOM without a decodable image".
    gdcm::Reader plain;
    plain.SetFileName(path.c_str());
    GIMM_CHECK(plain.Read(), path << ": not a DICOM file (GDCM cannot parse it)");
    const gdcm::TransferSyntax& ts = plain.GetFile().GetHeader().GetDataSetTransferSyntax();
    GIMM_FAIL(path << ": DICOM without an image this build can decode (transfer syntax "
                   << gdcm::TransferSyntax::GetTSString(ts) << ")");
  }
  const gdcm::File& file = reader.GetFile();
  const gdcm::Image& image = reader.GetImage();
  detail::TagReader tags(file, path);
  XaFrame out;
  out.path = path;

  // Modality: XA or RF.
  const auto modality = tags.text(0x0008, 0x0060, "Modality", "must be XA or RF", "absent");
  gdcm::MediaStorage ms;
  ms.SetFromFile(file);
  GIMM_CHECK(ms != gdcm::MediaStorage::EnhancedXAImageStorage,
             path << ": an Enhanced XA image: its geometry is in per-frame functional groups, "
                     "which gimm does not read yet (XA and XRF Image Storage are read)");
  const bool xa_class = ms == gdcm::MediaStorage::XRayAngiographicImageStorage ||
                        ms == gdcm::MediaStorage::XRayRadiofluoroscopingImageStorage;
  GIMM_CHECK((modality && (*modality == "XA" || *modality == "RF")) || (!modality && xa_class),
             path << ": not an X-ray angiogram: (0008,0060) Modality is "
                  << (modality ? "'" + *modality + "'" : std::string("absent")) << " (SOP class "
                  << (ms.GetString() ? ms.GetString() : "unknown") << "); XA or RF expected");

  // Pixels.
  const gdcm::PixelFormat& pf = image.GetPixelFormat();
  GIMM_CHECK(pf.GetSamplesPerPixel() == 1, path << ": (0028,0002) SamplesPerPixel is "
                                                << pf.GetSamplesPerPixel()
                                                << "; an angiogram has one sample per pixel");
  GIMM_CHECK(
      pf.GetBitsAllocated() == 8 || pf.GetBitsAllocated() == 16,
      path << ": (0028,0100) BitsAllocated is " << pf.GetBitsAllocated() << "; 8 or 16 expected");
  const int cols = int(image.GetDimension(0)), rows = int(image.GetDimension(1));
  out.frames = image.GetNumberOfDimensions() > 2 ? int(image.GetDimension(2)) : 1;
  GIMM_CHECK(rows > 0 && cols > 0 && rows <= 16384 && cols <= 16384 && out.frames > 0,
             path << ": image size " << cols << " x " << rows << " x " << out.frames
                  << " frames is out of range (1..16384 per side)");
  out.frame = options.frame.value_or(out.frames / 2);
  GIMM_CHECK(out.frame >= 0 && out.frame < out.frames,
             path << ": frame " << out.frame << " is out of range: the file has " << out.frames
                  << (out.frames == 1 ? " frame (index 0)"
                                      : " frames (0.." + std::to_string(out.frames - 1) + ")"));
  const std::size_t bytes = std::size_t(pf.GetBitsAllocated() / 8);
  const std::size_t frame_bytes = std::size_t(rows) * std::size_t(cols) * bytes;
  GIMM_CHECK(image.GetBufferLength() == frame_bytes * std::size_t(out.frames),
             path << ": pixel buffer of " << image.GetBufferLength() << " bytes, expected "
                  << frame_bytes * std::size_t(out.frames));
  GIMM_CHECK(image.GetBufferLength() <= (std::size_t(1) << 32),
             path << ": " << image.GetBufferLength() << " bytes of pixels is more than 4 GiB");
  // Before allocating: native pixels are in the file; compressed ones decode to at most
  // kMaxDicomCompression times their size (a bound on what a forged header makes gimm allocate).
  const std::uint64_t file_bytes = file_size_of(path);
  const bool encapsulated = image.GetTransferSyntax().IsEncapsulated();
  GIMM_CHECK(
      image.GetBufferLength() <= file_bytes * (encapsulated ? detail::kMaxDicomCompression : 1),
      path << ": " << cols << " x " << rows << " x " << out.frames << " frames of " << bytes
           << "-byte pixels need " << image.GetBufferLength() << " bytes, more than the "
           << file_bytes << "-byte file can hold"
           << (encapsulated
                   ? " at " + std::to_string(detail::kMaxDicomCompression) + ":1 compression"
                   : std::string()));
  // Native pixels shorter than the header's frames: GDCM copies the full frame size out of the
  // shorter value (libFuzzer, ASan: a heap read past the pixel data GDCM holds).
  if (!encapsulated) {
    const gdcm::ByteValue* stored = image.GetDataElement().GetByteValue();
    const std::uint64_t stored_bytes = stored ? std::uint64_t(stored->GetLength()) : 0;
    GIMM_CHECK(stored_bytes >= image.GetBufferLength(),
               path << ": (7FE0,0010) PixelData holds " << stored_bytes << " bytes, but " << cols
                    << " x " << rows << " x " << out.frames << " frames of " << bytes
                    << "-byte pixels need " << image.GetBufferLength());
  }
  std::vector<char> buffer(image.GetBufferLength());
  GIMM_CHECK(image.GetBuffer(buffer.data()),
             path << ": GDCM could not decode the pixels (transfer syntax "
                  << gdcm::TransferSyntax::GetTSString(image.GetTransferSyntax()) << ")");
  const bool is_signed = pf.GetPixelRepresentation() == 1;
  std::vector<double> values(std::size_t(rows) * cols);
  const char* frame_data = buffer.data() + frame_bytes * std::size_t(out.frame);
  for (std::size_t k = 0; k < values.size(); ++k) {
    if (bytes == 1)
      values[k] =
          is_signed ? double(std::int8_t(frame_data[k])) : double(std::uint8_t(frame_data[k]));
    else {
      std::uint16_t u;
      std::memcpy(&u, frame_data + 2 * k, 2);
      values[k] = is_signed ? double(std::int16_t(u)) : double(u);
    }
  }
  const gdcm::PhotometricInterpretation pi = image.GetPhotometricInterpretation();
  const bool monochrome1 = pi == gdcm::PhotometricInterpretation::MONOCHROME1;
  GIMM_CHECK(monochrome1 || pi == gdcm::PhotometricInterpretation::MONOCHROME2,
             path << ": (0028,0004) PhotometricInterpretation is "
                  << detail::trimmed(gdcm::PhotometricInterpretation::GetPIString(pi))
                  << "; MONOCHROME1 or MONOCHROME2 expected");
  if (monochrome1)
    for (double& v : values) v = -v;
  const std::string pi_name = detail::trimmed(gdcm::PhotometricInterpretation::GetPIString(pi));
  tags.uses.push_back({"(0028,0004)", "PhotometricInterpretation", pi_name,
                       monochrome1 ? "inverted to MONOCHROME2" : "used as is"});
  const Image<float> stored = detail::percentile_window(values, rows, cols);

  // Orientation of the stored pixels relative to the detector.
  const auto rotation = tags.numbers(0x0018, 0x7032, "FieldOfViewRotation",
                                     "undone (stored pixels turned back)", "absent: 0", 1);
  int rotation_deg = 0;
  if (rotation) {
    const double r = rotation->front();
    GIMM_CHECK(r == 0 || r == 90 || r == 180 || r == 270,
               path << ": (0018,7032) FieldOfViewRotation must be 0, 90, 180 or 270, got " << r);
    rotation_deg = int(r);
  }
  const auto flip = tags.text(0x0018, 0x7034, "FieldOfViewHorizontalFlip",
                              "undone (stored pixels flipped back)", "absent: NO");
  GIMM_CHECK(
      !flip || *flip == "YES" || *flip == "NO",
      path << ": (0018,7034) FieldOfViewHorizontalFlip must be YES or NO, got '" << *flip << "'");
  out.image = detail::to_detector_orientation(stored, rotation_deg, flip && *flip == "YES");
  // The shutters, in stored pixels like the image, turned the same way.
  if (const auto shutter =
          detail::shutter_field(tags, rows, cols, path, out.field_source, out.warnings)) {
    const Image<float> field =
        detail::to_detector_orientation(*shutter, rotation_deg, flip && *flip == "YES");
    out.field.resize(field.rows(), field.cols());
    for (std::size_t k = 0; k < field.size(); ++k) out.field.data()[k] = field.data()[k] > 0.5f;
  }
  CArm& carm = out.carm;
  carm.rows = out.image.rows();
  carm.cols = out.image.cols();

  // Angles and distances.
  carm.primary_deg = tags.required(0x0018, 0x1510, "PositionerPrimaryAngle", "primary angle, +LAO");
  carm.secondary_deg =
      tags.required(0x0018, 0x1511, "PositionerSecondaryAngle", "secondary angle, +cranial");
  carm.sid_mm = tags.required(0x0018, 0x1110, "DistanceSourceToDetector", "SID, mm");
  carm.sod_mm = tags.required(0x0018, 0x1111, "DistanceSourceToPatient", "SOD (to isocentre), mm");

  // Pixel pitch at the detector (row spacing, column spacing), in stored orientation.
  const auto imager =
      tags.numbers(0x0018, 0x1164, "ImagerPixelSpacing",
                   options.pitch_mm ? "overridden by the given pitch"
                                    : "pixel pitch at the detector (row\\column), mm",
                   "absent", 2);
  const auto intensifier = tags.numbers(
      0x0018, 0x1162, "IntensifierSize",
      !imager && !options.pitch_mm ? "pitch = IntensifierSize / Columns (fallback)" : "not needed",
      "absent", 1);
  double row_pitch = 0, col_pitch = 0;
  if (options.pitch_mm) {
    GIMM_CHECK(std::isfinite(*options.pitch_mm) && *options.pitch_mm > 0,
               "the given pixel pitch must be > 0 mm, got " << *options.pitch_mm);
    row_pitch = col_pitch = *options.pitch_mm;
  } else if (imager) {
    row_pitch = (*imager)[0];
    col_pitch = (*imager)[1];
  } else {
    GIMM_CHECK(intensifier, path << ": neither (0018,1164) ImagerPixelSpacing nor (0018,1162) "
                                    "IntensifierSize is present; give the detector pixel pitch: "
                                    "DicomReadOptions::pitch_mm, in mm");
    row_pitch = col_pitch = intensifier->front() / double(cols);
    // The other candidate, FieldOfViewDimensions / Columns, is reported, not used: on eight real
    // GE DL views (0.400 vs 0.3906 mm) the IntensifierSize rule fit at least as well.
    const auto fov = tags.numbers(0x0018, 0x1149, "FieldOfViewDimensions",
                                  "not used: the pitch it implies is reported", "absent", 0);
    std::ostringstream other;
    if (fov && !fov->empty())
      other << "; (0018,1149) FieldOfViewDimensions / Columns would give "
            << fov->front() / double(cols) << " mm";
    out.warnings.push_back(
        "(0018,1164) ImagerPixelSpacing is absent: pixel pitch = (0018,1162) "
        "IntensifierSize / Columns = " +
        std::to_string(col_pitch) + " mm" + other.str() +
        " (worth a few px at the field's edge; a per-view pitch overrides)");
  }
  GIMM_CHECK(row_pitch > 0 && col_pitch > 0,
             path << ": pixel pitch must be > 0 mm, got " << row_pitch << " x " << col_pitch);
  if (rotation_deg == 90 || rotation_deg == 270) std::swap(row_pitch, col_pitch);
  carm.pixel_mm = col_pitch;
  if (row_pitch != col_pitch) carm.pixel_row_mm = row_pitch;

  // Principal point: the detector's centre placed in the image when the file says where the
  // field of view sits on the detector; else the image centre.
  const auto fov_origin = tags.numbers(0x0018, 0x7030, "FieldOfViewOrigin",
                                       "field of view's corner on the detector (row\\column, "
                                       "detector pixels)",
                                       "absent: principal point at the image centre", 2);
  const auto active = tags.numbers(0x0018, 0x7026, "DetectorActiveDimensions",
                                   "detector size (row\\column), mm", "absent", 2);
  const auto element = tags.numbers(0x0018, 0x7022, "DetectorElementSpacing",
                                    "detector element pitch (row\\column), mm", "absent", 2);
  if (fov_origin && active && element) {
    GIMM_CHECK(imager, path << ": FieldOfViewOrigin needs (0018,1164) ImagerPixelSpacing");
    // Stored pixel j covers detector pixels origin + j * bin ... ; its centre is at detector
    // pixel origin + (j + 0.5) bin - 0.5, bin = pitch / element pitch.
    Eigen::Vector2d pp_stored;              // (u = column, v = row) in stored orientation
    for (int axis = 0; axis < 2; ++axis) {  // 0: row, 1: column
      GIMM_CHECK((*element)[axis] > 0, path << ": (0018,7022) DetectorElementSpacing must be > 0");
      const double centre = (*active)[axis] / (*element)[axis] / 2.0 - 0.5;
      const double bin = (axis == 0 ? (*imager)[0] : (*imager)[1]) / (*element)[axis];
      const double stored_index = (centre - (*fov_origin)[axis] + 0.5) / bin - 0.5;
      pp_stored[1 - axis] = stored_index;
    }
    // Carry the point through the same flip and turns as the pixels.
    Eigen::Vector2d p = pp_stored;
    int w = cols, h = rows;
    if (flip && *flip == "YES") p.x() = w - 1 - p.x();
    for (int q = 0; q < (rotation_deg / 90) % 4; ++q) {
      p = Eigen::Vector2d(p.y(), w - 1 - p.x());
      std::swap(w, h);
    }
    carm.principal_point = p;
  }

  // Patient position and table.
  const auto position = tags.text(0x0018, 0x5100, "PatientPosition", "table axes to patient axes",
                                  "absent: HFS assumed");
  if (!position)
    out.warnings.push_back(
        "(0018,5100) PatientPosition is absent: head-first supine (HFS) assumed");
  else
    GIMM_CHECK(*position == "HFS" || *position == "FFS",
               path << ": (0018,5100) PatientPosition is " << *position
                    << "; gimm maps the table for HFS and FFS only");
  carm.patient_position =
      position && *position == "FFS" ? PatientPosition::FFS : PatientPosition::HFS;
  auto table = detail::read_table(tags);
  out.table_source = table.source;
  for (auto& w : table.warnings) out.warnings.push_back(std::move(w));
  const auto& [lateral, vertical, longitudinal] = table.values;
  const auto or_zero = [](const std::optional<std::vector<double>>& v) {
    return v ? v->front() : 0.0;
  };
  carm.table_mm = {or_zero(lateral), or_zero(vertical), or_zero(longitudinal)};
  carm.reference_table_mm = carm.table_mm;
  out.tags = std::move(tags.uses);
  try {
    carm.validate();
  } catch (const Error& e) {
    throw Error(path + ": " + e.what());
  }
  return out;
}

/// The explain report: every tag looked at, its value and use; then the warnings.
inline std::string explain(const XaFrame& frame) {
  std::ostringstream os;
  const CArm& c = frame.carm;
  os << frame.path << ": frame " << frame.frame << " of " << frame.frames << ", " << c.cols << " x "
     << c.rows << " px; table: " << frame.table_source << "\n";
  for (const auto& t : frame.tags)
    os << "  " << t.tag << " " << t.name << " = " << t.value << "  -> " << t.use << "\n";
  const auto mm = [](const Eigen::Vector3d& v) {
    std::ostringstream s;
    s << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
    return s.str();
  };
  os << "  table (lateral, vertical, longitudinal): " << mm(c.table_mm) << " mm, reference "
     << mm(c.reference_table_mm) << " mm; the patient moved " << mm(c.table_shift())
     << " mm (patient x, y, z; " << to_string(c.patient_position)
     << "), so this view's isocentre is " << mm(c.isocenter) << " - " << mm(c.table_shift())
     << " = " << mm(c.view_isocenter()) << " mm\n";
  os << "  exposed field: " << frame.field_source << "\n";
  for (const auto& w : frame.warnings) os << "  warning: " << w << "\n";
  return os.str();
}

/// Writes `image` ([0, 1], MONOCHROME2) as a single-frame 16-bit XA file with the C-arm's
/// angles, distances, pixel pitch and table (GE-style private tags when `ge_table`, else the
/// standard ones). For exporting renders and for tests; the principal point must be the centre.
inline void write_xa_dicom(const std::string& path, const Image<float>& image, const CArm& carm,
                           bool ge_table = false) {
  detail::quiet_gdcm();
  carm.validate();
  GIMM_CHECK(image.rows() == carm.rows && image.cols() == carm.cols,
             path << ": image is " << image.cols() << " x " << image.rows() << ", C-arm "
                  << carm.cols << " x " << carm.rows);
  GIMM_CHECK(
      !carm.principal_point ||
          (*carm.principal_point - Eigen::Vector2d((carm.cols - 1) / 2.0, (carm.rows - 1) / 2.0))
                  .norm() < 1e-9,
      path << ": write_xa_dicom writes centred principal points only");
  gdcm::ImageWriter writer;
  gdcm::Image& out = writer.GetImage();
  out.SetNumberOfDimensions(2);
  out.SetDimension(0, unsigned(image.cols()));
  out.SetDimension(1, unsigned(image.rows()));
  out.SetPixelFormat(gdcm::PixelFormat::UINT16);
  out.SetPhotometricInterpretation(gdcm::PhotometricInterpretation::MONOCHROME2);
  out.SetTransferSyntax(gdcm::TransferSyntax::ExplicitVRLittleEndian);
  // GDCM writes an XA image's spacing as ImagerPixelSpacing (row \ column).
  out.SetSpacing(0, carm.pixel_mm);
  out.SetSpacing(1, carm.row_pixel_mm());
  std::vector<std::uint16_t> pixels(std::size_t(image.rows()) * image.cols());
  for (int r = 0; r < image.rows(); ++r)
    for (int c = 0; c < image.cols(); ++c) {
      const float v = image(r, c);
      GIMM_CHECK(std::isfinite(v), path << ": pixel (" << r << ", " << c << ") is " << v);
      pixels[std::size_t(r) * image.cols() + c] =
          std::uint16_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 65535.0f));
    }
  gdcm::DataElement pixel_data(gdcm::Tag(0x7fe0, 0x0010));
  pixel_data.SetByteValue(reinterpret_cast<const char*>(pixels.data()),
                          std::uint32_t(pixels.size() * 2));
  out.SetDataElement(pixel_data);

  gdcm::File& file = writer.GetFile();
  gdcm::DataSet& ds = file.GetDataSet();
  const auto put = [&](std::uint16_t g, std::uint16_t e, gdcm::VR vr, std::string value) {
    if (value.size() % 2) value += ' ';
    gdcm::DataElement de(gdcm::Tag(g, e));
    de.SetVR(vr);
    de.SetByteValue(value.data(), std::uint32_t(value.size()));
    ds.Replace(de);
  };
  const auto number = [](double x) {
    std::ostringstream os;
    os.precision(12);  // DS holds at most 16 characters
    os << x;
    std::string s = os.str();
    GIMM_CHECK(s.size() <= 16, "write_xa_dicom: " << x << " does not fit a DICOM DS");
    return s;
  };
  gdcm::UIDGenerator uid;
  put(0x0008, 0x0016, gdcm::VR::UI,
      gdcm::MediaStorage::GetMSString(gdcm::MediaStorage::XRayAngiographicImageStorage));
  put(0x0008, 0x0018, gdcm::VR::UI, uid.Generate());
  put(0x0008, 0x0060, gdcm::VR::CS, "XA");
  put(0x0018, 0x1510, gdcm::VR::DS, number(carm.primary_deg));
  put(0x0018, 0x1511, gdcm::VR::DS, number(carm.secondary_deg));
  put(0x0018, 0x1110, gdcm::VR::DS, number(carm.sid_mm));
  put(0x0018, 0x1111, gdcm::VR::DS, number(carm.sod_mm));
  put(0x0018, 0x5100, gdcm::VR::CS, to_string(carm.patient_position));
  if (ge_table) {
    put(0x0019, 0x0010, gdcm::VR::LO, "DLX_SERIE_01");  // GE DL's table block
    put(0x0019, 0x1021, gdcm::VR::DS, number(carm.table_mm.y()));
    put(0x0019, 0x1022, gdcm::VR::DS, number(carm.table_mm.z()));
    put(0x0019, 0x1023, gdcm::VR::DS, number(carm.table_mm.x()));
  } else {
    put(0x300A, 0x0128, gdcm::VR::DS, number(carm.table_mm.y()));
    put(0x300A, 0x0129, gdcm::VR::DS, number(carm.table_mm.z()));
    put(0x300A, 0x012A, gdcm::VR::DS, number(carm.table_mm.x()));
  }
  std::ostringstream bytes;
  writer.SetStream(bytes);
  GIMM_CHECK(writer.Write(), path << ": GDCM could not encode the file");
  write_file_atomic(path, bytes.str());
}

}  // namespace gimm
