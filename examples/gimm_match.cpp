// gimm-match: matches coronary points between two angiograms (the GIMM matcher, or the
// training-free baselines in dataset mode).
//   gimm-match --image-a A.png --image-b B.png [--weights W.safetensors]
//              [--class-a ID --class-b ID] [--camera-a A.json --camera-b B.json]
//              [--gate hard|soft|logit|none] [--tau PX] [--delta PX] [--snap] [--input-size N]
//              [--threshold C]
//              [--pair ID] [--out matches.json] [--picture pair.png]
//   gimm-match --dataset DIR [--weights W.safetensors] --out PRED_DIR [--split all|train|val|test]
//              [--geometry cameras|matches] [--gate ...]
//   gimm-match --dataset DIR --method epipolar|oracle --out PRED_DIR [--sigma PX] [--seed S]
//              [--max-points N]
//   gimm-match --method geometric --camera-a A.json --camera-b B.json --image-a A.png
//              --image-b B.png [--tree tree.json] [--tree-vtk tree.vtk] [--tolerance PX]
//   gimm-match --dataset DIR --method geometric [--segment] [--images formed] --out PRED_DIR
//   gimm-match --dicom-a A.dcm --dicom-b B.dcm [--frame-a N --frame-b M] [--method geometric]
//              [--system LCA|RCA] [--pixel-a/-b MM] [--table-a/-b L V G] [--isocenter-a/-b X Y Z]
//              [--camera-a/-b C.json] [--out m.json] [--picture p.png] [--tree t.json]
//              [--tree-vtk t.vtk]
// Single pair with cameras: --landmark UA VA UB VB (repeatable) moves B's camera onto points
// marked in both views (geometry/landmark_alignment.hpp), for pairs whose table is not recorded.
// Single pair, either method: --tree/--tree-vtk write the matches triangulated with both cameras
// (match/reconstruct.hpp; the learned matcher's dropped past --max-reprojection).
// The matchers themselves are in examples/match/ (methods.hpp), one file each.
// DICOM (pipeline/dicom_pair.hpp, docs/dicom.md): images, cameras and exposed fields from the
// files' tags, B's table relative to A's, each view's geometry correctable on its own; the
// learned matcher's view classes from the angles and --system (or --class-a/b); real C-arm
// geometry is off by a few px, so the gate (--delta) and the geometric tolerance default to 5 px.
// Every single-pair mode matches inside the exposed fields (shutters, or found in the images).
// Dataset mode, any method using cameras: --camera-error-deg D --camera-error-mm M give the
// matcher cameras off by D degrees and M mm (geometry/camera_error.hpp), for stability sweeps;
// --noise-photons N --blur-px S degrade the images the matcher sees (render/image_degradation.hpp).
// The geometric matcher (match/geometric.hpp) needs the cameras; it uses the dataset's vessel
// masks unless --segment, and segments the images itself in the single-pair mode.
// Without --weights the shipped weights are used (weights/README.md), at the input size they
// record. Writes the gimm-matches/1 predictions format (docs/evaluation.md) that gimm-eval scores.
// The dataset mode matches every pair of a gimm-dataset (view classes from the pair files, cameras
// from the views unless --geometry matches, which estimates F from the matches as the
// reference does) into PRED_DIR/<patient>/<pair>.json, with a progress line. Outputs are all or
// nothing: a failed run (a full disk) leaves PRED_DIR, or the single-pair files, as they were.
// Images: 8- or 16-bit PNG, grey or colour (converted to grey), of any sizes; see
// include/gimm/match/learned.hpp for padding, resizing and where F comes from.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

#include "cli_common.hpp"
#include "gimm/geometry/camera_error.hpp"
#include "gimm/geometry/epipolar.hpp"
#include "gimm/geometry/landmark_alignment.hpp"
#include "gimm/io/camera_json.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/png.hpp"
#include "gimm/labels/views.hpp"
#include "gimm/match/baselines.hpp"
#include "gimm/match/field_of_view.hpp"
#include "gimm/match/geometric.hpp"
#include "gimm/match/learned_options.hpp"
#include "gimm/match/matches.hpp"
#include "gimm/pipeline/dicom_pair.hpp"
#include "gimm/pipeline/match_run.hpp"
#include "gimm/render/image_degradation.hpp"
#include "match/methods.hpp"

namespace {

std::optional<gimm::Camerad> read_camera(const std::string& path) {
  if (path.empty()) return std::nullopt;
  return gimm::camera_from_json(gimm::read_json_file(path), path);
}

/// A view given as a PNG (`flag`): the matchers need at least 16 x 16 px.
gimm::Image<float> read_view_png(const char* flag, const std::string& path) {
  gimm::Image<float> image = gimm::read_png_unit(path);
  GIMM_CHECK(image.rows() >= 16 && image.cols() >= 16,
             flag << " '" << path << "' is " << image.cols() << " x " << image.rows()
                  << " px; the matchers need at least 16 x 16");
  return image;
}

/// Every flag's value; what no flag sets keeps the library's default.
struct Flags {
  std::string image_a, image_b, weights, camera_a, camera_b, gate = "hard", out, picture, pair;
  std::string dataset, split = "all", geometry = "cameras", method = "learned", images = "auto";
  double sigma = 1.0;
  std::uint64_t seed = 0;
  gimm::EpipolarBaselineOptions epi;
  int class_a = 0, class_b = 0, input_size = 0;
  gimm::MatchOptions options;
  gimm::GeometricOptions geometric;
  gimm::CameraError camera_error;
  gimm::ImageDegradation degradation;
  bool segment = false, exact_vesselness = false, keep_catheter = false;
  double min_confidence = 0;
  std::string tree, tree_vtk, dicom_a, dicom_b, system_name;
  int frame_a = -1, frame_b = -1;
  std::vector<double> isocenter, isocenter_a, isocenter_b, table_a, table_b;
  std::vector<double> landmarks;  // UA VA UB VB per --landmark
  double pixel_a = 0, pixel_b = 0;
  double max_reprojection = 0;
  float threshold = 0;
  CLI::Option* threshold_flag = nullptr;
  CLI::Option* input_size_flag = nullptr;
};

/// What to match and how: the inputs, the dataset mode, the method.
void add_input_flags(CLI::App& app, Flags& f) {
  app.add_option("--image-a", f.image_a, "view A, PNG (8 or 16 bit)")->check(CLI::ExistingFile);
  app.add_option("--image-b", f.image_b, "view B, PNG, same size as A")->check(CLI::ExistingFile);
  app.add_option("--dataset", f.dataset, "match every pair of this gimm-dataset (--out: a folder)")
      ->check(CLI::ExistingDirectory);
  app.add_option("--split", f.split, "dataset mode: all|train|val|test")
      ->check(CLI::IsMember({"all", "train", "val", "test"}))
      ->capture_default_str();
  app.add_option("--images", f.images,
                 "dataset mode: rendered (<view>.png) | formed (<view>.formed.png as a C-arm "
                 "forms it, matched inside <view>.field.png; gimm-dataset --formation) | auto "
                 "(formed where the dataset has them, as a clinical-style dataset does)")
      ->check(CLI::IsMember({"auto", "rendered", "formed"}))
      ->capture_default_str();
  app.add_option("--geometry", f.geometry, "dataset mode: F from the view cameras or the matches")
      ->check(CLI::IsMember({"cameras", "matches"}))
      ->capture_default_str();
  app.add_option("--method", f.method,
                 "learned (the GIMM network) | geometric (epipolar DP, needs cameras) | epipolar "
                 "| oracle (training-free, dataset mode; match/pair_matcher.hpp)")
      ->check(CLI::IsMember({"learned", "epipolar", "oracle", "geometric"}))
      ->capture_default_str();
  app.add_option("--weights", f.weights,
                 "learned: matcher weights, safetensors (default: the shipped weights, " +
                     gimm::cli::default_weights_hint() + ")")
      ->check(CLI::ExistingFile);
}

/// The baselines', the geometric matcher's and the dataset mode's stability-sweep flags.
void add_method_flags(CLI::App& app, Flags& f) {
  app.add_option("--sigma", f.sigma, "oracle: Gaussian noise on the B side, px per axis")
      ->capture_default_str()
      ->check(gimm::cli::at_least(0));
  app.add_option("--seed", f.seed, "oracle/epipolar/camera errors: random seed")
      ->capture_default_str();
  app.add_option("--max-points", f.epi.max_points, "epipolar: A vessel pixels sampled per pair")
      ->capture_default_str();
  app.add_option("--tolerance", f.geometric.epipolar_tolerance_px,
                 "geometric: epipolar tolerance, px (calibration error of real C-arms)")
      ->capture_default_str()
      ->check(gimm::cli::Positive);
  app.add_option("--junction-mm", f.geometric.junction_mm,
                 "geometric, segmenting: tree prior, how far in 3D the matches of two chains "
                 "meeting in A may be, mm (0 = off)")
      ->capture_default_str()
      ->check(gimm::cli::at_least(0));
  app.add_option("--min-confidence", f.min_confidence,
                 "geometric: the DP margin a match needs at 4/3 px per mm at the isocentre (the "
                 "256 px phantoms), scaled with the images' pixels per mm (default 0.5 with "
                 "masks, 1 segmenting; docs/geometric-matcher.md)")
      ->check(gimm::cli::at_least(0));
  app.add_option("--order-cost", f.geometric.w_order,
                 "geometric: cost of going back along a chain of B (ordering), 0 = no term")
      ->capture_default_str()
      ->check(gimm::cli::at_least(0));
  app.add_flag("--keep-catheter", f.keep_catheter,
               "geometric, segmenting: keep the chains that look like the catheter or a field "
               "edge (long and straight, or leaving the field at an even calibre); by default "
               "they are dropped before matching (docs/geometric-matcher.md)");
  app.add_option("--camera-error-deg", f.camera_error.deg,
                 "dataset mode: rotate each view's camera given to the matcher by this many "
                 "degrees about both axes across the view (random signs, --seed), images exact")
      ->capture_default_str()
      ->check(gimm::cli::in_range(0, 45, true));
  app.add_option("--camera-error-mm", f.camera_error.mm,
                 "dataset mode: shift each view's camera by this many mm (random direction)")
      ->capture_default_str()
      ->check(gimm::cli::in_range(0, 1000, true));
  app.add_option("--noise-photons", f.degradation.photons,
                 "dataset mode: Poisson noise on the images the matcher sees, photons per "
                 "unattenuated pixel (render/image_degradation.hpp; 0 = none)")
      ->capture_default_str()
      ->check(gimm::cli::at_least(0));
  app.add_option("--blur-px", f.degradation.blur_px,
                 "dataset mode: Gaussian blur of the images the matcher sees, sigma px (0 = none)")
      ->capture_default_str()
      ->check(gimm::cli::at_least(0));
  app.add_flag("--segment", f.segment,
               "geometric, dataset mode: segment the images instead of using the vessel masks");
  app.add_flag("--exact-vesselness", f.exact_vesselness,
               "geometric, segmenting: exact Gaussian-derivative kernels (the slow reference path; "
               "docs/geometric-matcher.md gives both paths' figures)");
}

/// The triangulated tree, and the DICOM views with their per-view corrections.
void add_tree_and_dicom_flags(CLI::App& app, Flags& f) {
  app.add_option("--tree", f.tree,
                 "single pair with cameras: the matches with their triangulated points (JSON)");
  app.add_option("--tree-vtk", f.tree_vtk,
                 "single pair with cameras: the triangulated points as VTK polydata");
  app.add_option("--max-reprojection", f.max_reprojection,
                 "learned, --tree: drop points reprojecting further than this, px (default: the "
                 "hard gate's --delta)")
      ->check(gimm::cli::Positive);
  app.add_option("--dicom-a", f.dicom_a, "view A: XA/XRF DICOM file (image and C-arm geometry)")
      ->check(CLI::ExistingFile);
  app.add_option("--dicom-b", f.dicom_b,
                 "view B: XA/XRF DICOM file; its table is taken relative "
                 "to A's")
      ->check(CLI::ExistingFile);
  app.add_option("--isocenter", f.isocenter,
                 "with --dicom-a/b: A's isocentre X Y Z, patient mm, B's at A's table (default "
                 "0: --tree points relative to it)")
      ->expected(3)
      ->check(gimm::cli::position_mm);
  app.add_option("--isocenter-a", f.isocenter_a, "with --dicom-a/b: A's isocentre X Y Z only")
      ->expected(3)
      ->check(gimm::cli::position_mm);
  app.add_option("--isocenter-b", f.isocenter_b,
                 "with --dicom-a/b: B's isocentre X Y Z at its own table (default: A's)")
      ->expected(3)
      ->check(gimm::cli::position_mm);
  app.add_option("--table-a", f.table_a,
                 "with --dicom-a/b: A's table LATERAL VERTICAL LONGITUDINAL, mm, replacing the "
                 "file's")
      ->expected(3)
      ->check(gimm::cli::position_mm);
  app.add_option("--table-b", f.table_b, "with --dicom-a/b: B's table, as --table-a")
      ->expected(3)
      ->check(gimm::cli::position_mm);
  app.add_option("--pixel-a", f.pixel_a,
                 "with --dicom-a/b: A's detector pixel pitch, mm, replacing the file's")
      ->check(gimm::cli::pitch_mm);
  app.add_option("--pixel-b", f.pixel_b, "with --dicom-a/b: B's pitch, as --pixel-a")
      ->check(gimm::cli::pitch_mm);
  app.add_option("--frame-a", f.frame_a, "frame of --dicom-a, 0-based (default: the middle one)")
      ->check(gimm::cli::at_least(0));
  app.add_option("--frame-b", f.frame_b, "frame of --dicom-b, 0-based (default: the middle one)")
      ->check(gimm::cli::at_least(0));
  app.add_option("--landmark", f.landmarks,
                 "single pair with cameras: UA VA UB VB, one point marked in both views, pixels "
                 "(a catheter tip, an ostium, a bifurcation); B's C-arm is moved so that the "
                 "landmarks lie on their epipolar lines (an unrecorded table move). Repeat it: two "
                 "fix both directions across the baseline")
      ->expected(4)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  app.add_option("--system", f.system_name,
                 "LCA|RCA: the injected system, for view classes from DICOM angles (default: the "
                 "nearest of all 11 classes)")
      ->check(CLI::IsMember({"LCA", "RCA"}));
}

/// The learned matcher: view classes, cameras, the gate, threshold and size; the outputs.
void add_learned_and_output_flags(CLI::App& app, Flags& f) {
  app.add_option("--class-a", f.class_a, "view class of A: 1..11, 0 = unknown")
      ->capture_default_str()
      ->check(CLI::Range(0, 11));
  app.add_option("--class-b", f.class_b, "view class of B: 1..11, 0 = unknown")
      ->capture_default_str()
      ->check(CLI::Range(0, 11));
  app.add_option("--camera-a", f.camera_a,
                 "camera of A (JSON): gate with the exact F; with --dicom-a/b it replaces the "
                 "geometry read from A's file")
      ->check(CLI::ExistingFile);
  app.add_option("--camera-b", f.camera_b, "camera of B (JSON)")->check(CLI::ExistingFile);
  app.add_option("--gate", f.gate,
                 "epipolar gate: hard|soft|logit|none (default: the gate the weights record - "
                 "the shipped ones: hard, 4 px, --snap - else hard)")
      ->check(CLI::IsMember({"hard", "soft", "logit", "none"}));
  app.add_option("--tau", f.options.gate.tau, "soft/logit gate temperature, px")
      ->capture_default_str()
      ->check(gimm::cli::Positive);
  app.add_option("--delta", f.options.gate.delta_px,
                 "hard gate threshold, px (default: the weights' record, else 2; 5 with DICOM)")
      ->check(gimm::cli::Positive);
  f.threshold_flag =
      app.add_option("--threshold", f.threshold,
                     "learned: coarse confidence a match needs, in [0, 1) (default: the value "
                     "the weights record)")
          ->check(gimm::cli::in_range(0.0, 1.0, false));
  app.add_flag("--snap", f.options.snap_to_epipolar,
               "move each B point onto its epipolar line after gating (needs a gate; default: "
               "as the weights record)");
  f.input_size_flag =
      app.add_option(
             "--input-size", f.input_size,
             "resize the longer side to N before matching (0: as is; default: the size the weights "
             "were trained at, as they record it)")
          ->check(gimm::cli::zero_or_in(16, 4096));
  app.add_option("--pair", f.pair,
                 "pair id written into the matches file, e.g. phantom-0000/LCA_00-01");
  app.add_option("--out", f.out,
                 "matches file (gimm-matches/1 JSON); default: print a summary only");
  app.add_option("--picture", f.picture, "PNG of the two views with the matches drawn");
}

/// The learned matcher's weights (given or shipped) and the flags given for it; what no flag
/// sets comes from the weights' record (examples/match/match_learned.cpp).
gimm_match::LearnedChoice learned_choice(const CLI::App& app, const Flags& f) {
  gimm_match::LearnedChoice choice;
  choice.weights = f.weights.empty() ? gimm::cli::default_weights() : f.weights;
  if (f.threshold_flag->count()) choice.threshold = f.threshold;
  if (f.input_size_flag->count()) choice.input_size = f.input_size;
  // Real DICOM geometry keeps its own wider --delta default, set in load_dicom_views.
  if (app.count("--gate")) choice.gate.mode = f.options.gate.mode;
  if (app.count("--delta") || !f.dicom_a.empty()) choice.gate.delta_px = f.options.gate.delta_px;
  if (app.count("--snap")) choice.gate.snap = f.options.snap_to_epipolar;
  choice.gate_name = f.gate;
  choice.max_reprojection = f.max_reprojection;
  return choice;
}

/// A flag of one method given to another, or of a gate to another gate, would be silently
/// ignored: refused. The geometric flags that every mode shares are applied here.
void check_method_flags(const CLI::App& app, Flags& f) {
  const std::pair<const char*, const char*> method_flags[] = {{"--tolerance", "geometric"},
                                                              {"--order-cost", "geometric"},
                                                              {"--junction-mm", "geometric"},
                                                              {"--min-confidence", "geometric"},
                                                              {"--segment", "geometric"},
                                                              {"--exact-vesselness", "geometric"},
                                                              {"--keep-catheter", "geometric"},
                                                              {"--sigma", "oracle"},
                                                              {"--max-points", "epipolar"},
                                                              {"--gate", "learned"},
                                                              {"--tau", "learned"},
                                                              {"--delta", "learned"},
                                                              {"--snap", "learned"},
                                                              {"--threshold", "learned"},
                                                              {"--input-size", "learned"},
                                                              {"--max-reprojection", "learned"},
                                                              {"--class-a", "learned"},
                                                              {"--class-b", "learned"},
                                                              {"--system", "learned"}};
  for (const auto& [flag, owner] : method_flags)
    GIMM_USAGE_CHECK(app.count(flag) == 0 || f.method == owner,
                     flag << " is for --method " << owner << ", not " << f.method);
  GIMM_USAGE_CHECK(f.weights.empty() || f.method == "learned",
                   "--weights is for --method learned, not " << f.method);
  if (app.count("--gate")) {
    GIMM_USAGE_CHECK(
        f.gate != "none" || ((app.count("--snap") == 0 || !f.options.snap_to_epipolar) &&
                             app.count("--delta") == 0 && app.count("--tau") == 0),
        "--gate none: --snap, --delta and --tau need a gate");
    GIMM_USAGE_CHECK(f.gate != "hard" || app.count("--tau") == 0,
                     "--tau is the soft/logit gates' temperature, not --gate hard's");
    GIMM_USAGE_CHECK((f.gate != "soft" && f.gate != "logit") || app.count("--delta") == 0,
                     "--delta is --gate hard's threshold, not --gate " << f.gate << "'s");
  }
  GIMM_USAGE_CHECK(!f.keep_catheter || f.segment || f.dataset.empty(),
                   "--keep-catheter is about segmented chains: with --dataset it needs "
                   "--segment (without it the matcher uses the vessel masks)");
  if (f.keep_catheter)
    f.geometric.catheter.min_length_mm = 0, f.geometric.catheter.field_edge_px = 0;
  GIMM_USAGE_CHECK(app.count("--exact-vesselness") == 0 || f.segment || f.dataset.empty(),
                   "--exact-vesselness changes the segmentation: with --dataset it needs --segment "
                   "(without it the matcher uses the vessel masks)");
  // Every mode segments with it: a dataset (--segment), a pair of images, a pair of DICOMs.
  f.geometric.segmentation.vesselness.exact_derivatives = f.exact_vesselness;
  if (app.count("--min-confidence"))  // whichever of the two thresholds the mode uses
    f.geometric.min_confidence = f.geometric.min_confidence_segmented = f.min_confidence;
}

/// --dataset: every pair of the dataset, through gimm::match_dataset.
int match_dataset_mode(const CLI::App& app, Flags& f) {
  GIMM_USAGE_CHECK(f.image_a.empty() && f.image_b.empty() && f.camera_a.empty() &&
                       f.camera_b.empty() && f.dicom_a.empty() && f.dicom_b.empty() &&
                       f.picture.empty() && f.pair.empty() && f.tree.empty() &&
                       f.tree_vtk.empty() && f.class_a == 0 && f.class_b == 0 &&
                       f.landmarks.empty(),
                   "--dataset matches a whole dataset (classes and cameras from its files); it "
                   "takes no --image-a/b, --camera-a/b, --dicom-a/b, --class-a/b, --pair, "
                   "--picture, --tree/--tree-vtk or --landmark");
  GIMM_USAGE_CHECK(!f.out.empty(), "--dataset needs --out PRED_DIR");
  std::unique_ptr<gimm::PairMatcher> matcher;
  if (f.method == "learned") {
    matcher = gimm_match::learned_matcher(learned_choice(app, f), f.options);
  } else if (f.method == "geometric") {
    GIMM_USAGE_CHECK(
        f.geometry == "cameras",
        "--method geometric needs the cameras (--geometry cameras), got --geometry " << f.geometry);
    f.geometric.use_masks = !f.segment;
    matcher = gimm_match::geometric_matcher(f.geometric);
  } else {
    GIMM_USAGE_CHECK(std::isfinite(f.sigma) && f.sigma >= 0,
                     "--sigma must be >= 0, got " << f.sigma);
    matcher = gimm::baseline_matcher(f.method, f.sigma, f.epi, f.seed);
  }
  gimm::MatchRunOptions run;
  run.split = f.split;
  run.use_cameras = f.geometry == "cameras";
  run.images = f.images == "formed"     ? gimm::DatasetImages::formed
               : f.images == "rendered" ? gimm::DatasetImages::rendered
                                        : gimm::DatasetImages::automatic;
  run.camera_error = f.camera_error;
  run.degradation = f.degradation;
  run.seed = f.seed;
  run.report = gimm::stderr_reporter(false, "gimm-match: ");
  const gimm::DatasetReader reader(f.dataset);
  gimm::cli::flag_value("", [&] { run.validate(*matcher, reader); });
  const gimm::MatchRunSummary done = gimm::match_dataset(*matcher, f.dataset, f.out, run);
  std::printf("gimm-match: %zu pairs, %zu matches -> %s\n", done.pairs, done.matches,
              f.out.c_str());
  // Said, not silent: the reference's estimate needs min_matches (32) matches, and a pair
  // without F is written ungated.
  const bool estimates_F = f.method == "learned" && f.geometry == "matches" &&
                           f.options.gate.mode != gimm::GateMode::none;
  if (estimates_F && done.without_F > 0)
    std::printf(
        "gimm-match: --geometry matches: no F for %zu of %zu pairs (fewer than %d "
        "matches, or a degenerate fit); those pairs are not gated\n",
        done.without_F, done.pairs, f.options.gate.min_matches);
  return 0;
}

/// --dicom-a/b: images, cameras and fields from the files, each view's corrections applied;
/// the learned matcher's classes from the angles unless given. Real geometry widens the gate.
gimm_match::LoadedPair load_dicom_views(const CLI::App& app, Flags& f) {
  GIMM_USAGE_CHECK(!f.dicom_a.empty() && !f.dicom_b.empty(), "give both --dicom-a and --dicom-b");
  GIMM_USAGE_CHECK(f.image_a.empty() && f.image_b.empty(),
                   "--dicom-a/b carry the images: no --image-a/b");
  GIMM_USAGE_CHECK(f.isocenter.empty() || (f.isocenter_a.empty() && f.isocenter_b.empty()),
                   "--isocenter sets both views' isocentre: give it or --isocenter-a/-b, not both");
  gimm::DicomPairOptions o;
  const auto vec3 = [](const std::vector<double>& v) -> std::optional<Eigen::Vector3d> {
    if (v.empty()) return std::nullopt;
    return Eigen::Vector3d(v[0], v[1], v[2]);
  };
  for (auto [s, frame, pixel, table, iso, camera, flag_pixel] :
       {std::tuple{&o.a, f.frame_a, f.pixel_a, &f.table_a, &f.isocenter_a, &f.camera_a,
                   "--pixel-a"},
        {&o.b, f.frame_b, f.pixel_b, &f.table_b, &f.isocenter_b, &f.camera_b, "--pixel-b"}}) {
    if (frame >= 0) s->frame = frame;
    if (app.count(flag_pixel)) s->pitch_mm = pixel;
    s->table_mm = vec3(*table);
    s->isocenter = vec3(f.isocenter.empty() ? *iso : f.isocenter);
    s->camera = read_camera(*camera);
  }
  if (!f.system_name.empty()) o.system = gimm::parse_coronary_system(f.system_name);
  const bool classes_given = app.count("--class-a") && app.count("--class-b");
  o.need_classes = f.method == "learned" && !classes_given;
  o.need_system = o.need_classes;
  const gimm::DicomPair dp = gimm::load_dicom_pair(f.dicom_a, f.dicom_b, o);
  for (const auto& w : dp.warnings) std::cerr << "gimm-match: warning: " << w << "\n";
  for (const auto* v : {&dp.a, &dp.b}) {
    const bool is_a = v == &dp.a;
    const gimm::XaFrame& x = v->frame;
    std::cout << "gimm-match: view " << (is_a ? "A" : "B") << ": " << x.path << " frame " << x.frame
              << "/" << x.frames << ", " << x.carm.cols << "x" << x.carm.rows << ", primary "
              << x.carm.primary_deg << ", secondary " << x.carm.secondary_deg << " deg, table "
              << x.table_source << "; field " << v->field_source;
    if (o.need_classes) {
      (is_a ? f.class_a : f.class_b) = v->view_class;
      std::cout << "; " << v->class_note;
    }
    for (const auto& c : v->corrections) std::cout << "; " << c;
    std::cout << "\n";
  }
  // Real C-arm geometry: true correspondences lie ~2 px (median) and ~4.5 px (90th
  // percentile) off their epipolar lines; 5 px keeps ~93% of them (docs/dicom.md).
  if (app.count("--delta") == 0) f.options.gate.delta_px = 5.0;
  if (app.count("--tolerance") == 0) f.geometric.epipolar_tolerance_px = 5.0;
  std::cout << "gimm-match: real geometry: gate " << f.options.gate.delta_px
            << " px, geometric tolerance " << f.geometric.epipolar_tolerance_px << " px\n";
  return {dp.a.frame.image, dp.b.frame.image, dp.a.camera, dp.b.camera, dp.a.field, dp.b.field};
}

/// --image-a/b (and --camera-a/b): PNG views; a PNG carries no shutter, so the exposed fields
/// are found in the images.
gimm_match::LoadedPair load_png_views(const CLI::App& app, const Flags& f) {
  GIMM_USAGE_CHECK(!f.image_a.empty() && !f.image_b.empty(),
                   "give --image-a and --image-b (or --dicom-a and --dicom-b, or --dataset DIR)");
  for (const char* flag : {"--frame-a", "--frame-b", "--system", "--isocenter", "--isocenter-a",
                           "--isocenter-b", "--table-a", "--table-b", "--pixel-a", "--pixel-b"})
    GIMM_USAGE_CHECK(app.count(flag) == 0, flag << " goes with --dicom-a/b");
  GIMM_USAGE_CHECK(f.camera_a.empty() == f.camera_b.empty(),
                   "give both --camera-a and --camera-b (the pair's geometry), or neither");
  gimm_match::LoadedPair pair;
  pair.a = read_view_png("--image-a", f.image_a);
  pair.b = read_view_png("--image-b", f.image_b);
  pair.camera_a = read_camera(f.camera_a);
  pair.camera_b = read_camera(f.camera_b);
  pair.field_a = gimm::exposed_field(pair.a);
  pair.field_b = gimm::exposed_field(pair.b);
  return pair;
}

/// --landmark: B's camera moved onto the landmarks marked in both views, and what that did.
void align_to_landmark_flags(const Flags& f, gimm_match::LoadedPair& pair) {
  GIMM_USAGE_CHECK(f.landmarks.size() % 4 == 0,
                   "--landmark takes 4 numbers each time (UA VA UB VB), got " << f.landmarks.size()
                                                                              << " in all");
  GIMM_USAGE_CHECK(pair.camera_a && pair.camera_b,
                   "--landmark moves B's camera: give --camera-a/b (or --dicom-a/b)");
  std::vector<Eigen::Vector2d> a, b;
  for (std::size_t k = 0; k + 3 < f.landmarks.size(); k += 4) {
    a.emplace_back(f.landmarks[k], f.landmarks[k + 1]);
    b.emplace_back(f.landmarks[k + 2], f.landmarks[k + 3]);
  }
  const gimm::LandmarkAlignment r = gimm::cli::flag_value(
      "--landmark", [&] { return gimm::align_to_landmarks(*pair.camera_a, *pair.camera_b, a, b); });
  pair.camera_b = r.camera_b;
  std::printf(
      "gimm-match: B aligned to %zu landmark%s: its C-arm moved by (%.2f, %.2f, %.2f) mm "
      "(what a table move of the opposite does)%s\n",
      a.size(), a.size() == 1 ? "" : "s", r.shift_mm.x(), r.shift_mm.y(), r.shift_mm.z(),
      r.constrained_directions < 2 ? "; one direction fixed, a second landmark fixes the "
                                     "other"
                                   : "");
  for (std::size_t k = 0; k < a.size(); ++k)
    std::printf("gimm-match: landmark %zu: %.1f -> %.1f px from its epipolar line in B\n", k + 1,
                r.distance_before_px[k], r.distance_after_px[k]);
}

/// One pair, from DICOM files or from PNG images and camera JSON files.
int match_one_pair(const CLI::App& app, Flags& f, std::chrono::steady_clock::time_point start) {
  for (const char* flag :
       {"--camera-error-deg", "--camera-error-mm", "--noise-photons", "--blur-px", "--images"})
    GIMM_USAGE_CHECK(app.count(flag) == 0, flag << " is for the dataset mode (--dataset)");
  for (const auto& [flag, frame] : {std::pair{"--frame-a", f.frame_a}, {"--frame-b", f.frame_b}})
    GIMM_USAGE_CHECK(app.count(flag) == 0 || frame >= 0, flag << " must be >= 0, got " << frame);
  GIMM_USAGE_CHECK(app.count("--max-reprojection") == 0 || f.max_reprojection > 0,
                   "--max-reprojection must be > 0 px, got " << f.max_reprojection);
  gimm_match::LoadedPair loaded =
      !f.dicom_a.empty() || !f.dicom_b.empty() ? load_dicom_views(app, f) : load_png_views(app, f);
  if (loaded.camera_a && loaded.camera_b) {
    try {  // two views from one place (a file given twice) have no epipolar geometry
      static_cast<void>(gimm::fundamental_from_cameras(*loaded.camera_a, *loaded.camera_b));
    } catch (const gimm::Error& e) {
      const std::string a =
          f.camera_a.empty() ? "--dicom-a " + f.dicom_a : "--camera-a " + f.camera_a;
      const std::string b =
          f.camera_b.empty() ? "--dicom-b " + f.dicom_b : "--camera-b " + f.camera_b;
      throw gimm::Error(std::string(e.what()) + " (" + a + ", " + b + ")");
    }
  }
  if (!f.landmarks.empty()) align_to_landmark_flags(f, loaded);
  GIMM_USAGE_CHECK(f.method != "geometric" || (loaded.camera_a && loaded.camera_b),
                   "--method geometric on one pair needs the cameras: --camera-a and "
                   "--camera-b (or --dicom-a and --dicom-b)");
  GIMM_USAGE_CHECK((f.tree.empty() && f.tree_vtk.empty()) || loaded.camera_a,
                   "--tree and --tree-vtk triangulate with the cameras: give --camera-a/b");
  const gimm_match::PairOutputs outputs{f.pair, f.out, f.picture, f.tree, f.tree_vtk, start};
  if (f.method == "geometric")
    return gimm_match::match_geometric_pair(loaded, f.geometric, outputs);
  GIMM_USAGE_CHECK(f.method == "learned", "--method "
                                              << f.method
                                              << " matches a dataset's pairs (it needs their "
                                                 "masks or labels): give --dataset DIR");
  return gimm_match::match_learned_pair(learned_choice(app, f), f.options, loaded, f.class_a,
                                        f.class_b, outputs);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"gimm-match: coronary point matches between two angiograms (GIMM matcher)",
               "gimm-match"};
  Flags f;
  add_input_flags(app, f);
  add_method_flags(app, f);
  add_tree_and_dicom_flags(app, f);
  add_learned_and_output_flags(app, f);
  gimm::cli::option_flags() = {{"DicomReadOptions::pitch_mm", "--pixel-a, --pixel-b"},
                               {"MatchRunOptions::images", "--images"},
                               {"MatchRunOptions::camera_error", "--camera-error-deg/-mm"},
                               {"MatchRunOptions::use_cameras", "--geometry cameras"},
                               {"MatchRunOptions::degradation", "--noise-photons/--blur-px"},
                               {"CameraError::deg", "--camera-error-deg"},
                               {"CameraError::mm", "--camera-error-mm"},
                               {"ImageDegradation::photons", "--noise-photons"},
                               {"ImageDegradation::blur_px", "--blur-px"}};
  return gimm::cli::run(app, argc, argv, [&] {
    gimm::cli::keep_freed_memory();
    gimm::cli::refuse_outputs_over_inputs({{"--out", f.out},
                                           {"--picture", f.picture},
                                           {"--tree", f.tree},
                                           {"--tree-vtk", f.tree_vtk}},
                                          {{"--image-a", f.image_a},
                                           {"--image-b", f.image_b},
                                           {"--camera-a", f.camera_a},
                                           {"--camera-b", f.camera_b},
                                           {"--dicom-a", f.dicom_a},
                                           {"--dicom-b", f.dicom_b},
                                           {"--weights", f.weights},
                                           {"--dataset", f.dataset}},
                                          true);
    const auto start = std::chrono::steady_clock::now();
    f.options.gate.mode = gimm::parse_gate_mode(f.gate);
    check_method_flags(app, f);
    return f.dataset.empty() ? match_one_pair(app, f, start) : match_dataset_mode(app, f);
  });
}
