#pragma once
/// Two real X-ray angiograms in, ready to match: frames, cameras (table included), exposed
/// fields and view classes, with every per-view correction a user may need and every assumption
/// said. The job behind `gimm-match --dicom-a/--dicom-b` (needs gimm::dicom).
///
/// Per view, a user may override the frame, the pixel pitch, the table position, the reference
/// isocentre, or the whole camera (a camera JSON fitted by hand): the files are right most of
/// the time, and one bad tag must not force the other view's geometry to be given by hand.
/// B's table is taken relative to A's: A's isocentre is the reference (0 unless given).
///
/// Exposed field: the shutters of the file intersected with the field found in the image
/// (match/field_of_view.hpp); the matchers look inside it only.
///
/// View classes (what the learned matcher conditions on) come from the angles and the injected
/// system. Without the system, the nearest of all 11 classes is a guess: angles of left- and
/// right-coronary views overlap, and on eight real left-coronary views half got right-coronary
/// classes. The guess is reported; `need_system` refuses it instead (the learned matcher).
#include <optional>
#include <string>
#include <vector>

#include "gimm/geometry/camera.hpp"
#include "gimm/io/dicom.hpp"
#include "gimm/labels/views.hpp"
#include "gimm/match/field_of_view.hpp"

namespace gimm {

/// A user's corrections of one view; unset fields come from the file.
struct DicomViewSettings {
  std::optional<int> frame;                  ///< 0-based; default the middle frame
  std::optional<double> pitch_mm;            ///< detector pixel pitch, mm
  std::optional<Eigen::Vector3d> table_mm;   ///< (lateral, vertical, longitudinal), mm
  std::optional<Eigen::Vector3d> isocenter;  ///< this view's reference isocentre, patient mm
  std::optional<Camerad> camera;             ///< replaces the view's camera altogether
};

struct DicomPairOptions {
  DicomViewSettings a, b;
  std::optional<CoronarySystem> system;  ///< the injected system, for the view classes
  bool need_system = false;              ///< refuse to guess the system (learned matcher)
  bool need_classes = true;              ///< false: no view classes (geometric matcher)
  double far_class_deg = 5;  ///< a class further than this from its angle ranges is warned of
  bool detect_field = true;  ///< find the exposed field in the images too
  FieldOfViewOptions field;
};

/// One view, read and corrected.
struct DicomView {
  XaFrame frame;
  Camerad camera;
  Image<std::uint8_t> field;  ///< 1 where exposed
  std::string field_source;
  int view_class = kUnknownViewClass;
  std::string class_note;                ///< how the class was chosen
  std::vector<std::string> corrections;  ///< what the user's settings replaced
};

struct DicomPair {
  DicomView a, b;
  std::vector<std::string> warnings;  ///< the files' and the pair's, each naming its view
};

namespace detail {

inline void apply_view_settings(XaFrame& f, const DicomViewSettings& s,
                                std::vector<std::string>& corrections) {
  if (s.table_mm) {
    GIMM_CHECK(s.table_mm->allFinite(), f.path << ": the given table position must be finite");
    std::ostringstream os;
    os << "table (" << f.carm.table_mm.transpose() << ") from " << f.table_source
       << " replaced by (" << s.table_mm->transpose() << ") mm";
    corrections.push_back(os.str());
    f.carm.table_mm = *s.table_mm;
    f.table_source = "given";
  }
  if (s.isocenter) {
    GIMM_CHECK(s.isocenter->allFinite(), f.path << ": the given isocentre must be finite");
    f.carm.isocenter = *s.isocenter;
  }
}

/// The field: the file's shutters intersected with the field found in the image.
inline void view_field(DicomView& v, const DicomPairOptions& o) {
  const Image<float>& image = v.frame.image;
  v.field =
      v.frame.field.size() ? v.frame.field : Image<std::uint8_t>(image.rows(), image.cols(), 1);
  std::vector<std::string> sources;
  if (v.frame.field.size()) sources.push_back(v.frame.field_source);
  if (o.detect_field) {
    const Image<std::uint8_t> found = exposed_field(image, o.field);
    clear_outside(v.field, found);
    sources.push_back("found in the image");
  }
  v.field_source.clear();
  for (const auto& s : sources) v.field_source += (v.field_source.empty() ? "" : " and ") + s;
  if (v.field_source.empty()) v.field_source = "whole image";
  std::ostringstream os;
  os << " (" << int(std::lround(100 * field_fraction(v.field))) << "% of the image)";
  v.field_source += os.str();
}

/// The view class from the angles, said how; refused when the system is needed and not given.
inline void view_class(DicomView& v, const std::string& which, const DicomPairOptions& o,
                       std::vector<std::string>& warnings) {
  const CArm& carm = v.frame.carm;
  GIMM_CHECK(o.system || !o.need_system,
             "view " << which << " (" << v.frame.path << ", primary " << carm.primary_deg
                     << ", secondary " << carm.secondary_deg
                     << " deg): the learned matcher needs the view classes, and the injected "
                        "system (LCA or RCA) cannot be told from the angles: give it, or the "
                        "classes themselves");
  const ViewClassMatch m = view_class_from_angles(o.system, carm.primary_deg, carm.secondary_deg);
  v.view_class = m.id;
  std::ostringstream os;
  os << "class " << m.id << " (" << to_string(gimm::view_class(m.id).system) << " "
     << gimm::view_class(m.id).name << ", " << m.distance_deg << " deg from its ranges; "
     << (o.system ? "system given" : "system not given: the nearest of all 11 classes") << ")";
  v.class_note = os.str();
  if (m.distance_deg > o.far_class_deg) {
    std::ostringstream w;
    w << "view " << which << ": the nearest view class, " << m.id << ", is " << m.distance_deg
      << " deg from its angle ranges: the matcher sees a view it was not trained on";
    warnings.push_back(w.str());
  }
}

}  // namespace detail

/// Reads two XA DICOM views and prepares them for matching (see the header comment).
inline DicomPair load_dicom_pair(const std::string& path_a, const std::string& path_b,
                                 const DicomPairOptions& o = {}) {
  o.field.validate();
  DicomPair pair;
  const auto read = [&](const std::string& path, const DicomViewSettings& s, DicomView& v,
                        const char* which) {
    DicomReadOptions r;
    r.frame = s.frame;
    r.pitch_mm = s.pitch_mm;
    v.frame = read_xa_dicom(path, r);
    if (s.pitch_mm) {
      std::ostringstream os;
      os << "pixel pitch " << *s.pitch_mm << " mm given";
      v.corrections.push_back(os.str());
    }
    for (const auto& w : v.frame.warnings)
      pair.warnings.push_back(std::string("view ") + which + ": " + w);
    detail::apply_view_settings(v.frame, s, v.corrections);
  };
  read(path_a, o.a, pair.a, "A");
  read(path_b, o.b, pair.b, "B");
  set_table_reference(pair.b.frame, pair.a.frame);
  if (!o.b.isocenter) pair.b.frame.carm.isocenter = pair.a.frame.carm.isocenter;
  for (auto [v, s, which] : {std::tuple{&pair.a, &o.a, "A"}, {&pair.b, &o.b, "B"}}) {
    v->camera = v->frame.carm.camera();
    if (s->camera) {
      GIMM_CHECK(
          s->camera->rows() == v->frame.image.rows() && s->camera->cols() == v->frame.image.cols(),
          "view " << which << ": the given camera is for " << s->camera->cols() << " x "
                  << s->camera->rows() << " px, the frame is " << v->frame.image.cols() << " x "
                  << v->frame.image.rows());
      v->camera = *s->camera;
      v->corrections.push_back("camera given: the file's geometry is not used");
    }
    detail::view_field(*v, o);
    if (o.need_classes) detail::view_class(*v, which, o, pair.warnings);
  }
  return pair;
}

}  // namespace gimm
