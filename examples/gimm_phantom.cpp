// gimm-phantom: writes a procedural CCTA patient in ImageCAS form.
//   gimm-phantom --seed S --out DIR [--size small|imagecas|chest] [--dominance
//   auto|right|left|codominant]
//                [--noise HU] [--preview]
// Writes DIR/S.img.nii.gz (HU, int16), DIR/S.label.nii.gz (1 = coronary, uint8) and
// DIR/S.centerlines.json (the analytic centerline tree, world mm, LPS). --preview adds
// DIR/S.slice.png (axial slice through the heart, window [-200, 600] HU) and DIR/S.mip.png
// (coronal maximum-intensity projection, anterior view, patient's left on the image right).
// All or nothing: a failed run (a full disk) leaves DIR as it was.
#include <chrono>
#include <cstdio>
#include <filesystem>

#include "cli_common.hpp"
#include "gimm/anatomy/phantom.hpp"
#include "gimm/dataset/centerlines_json.hpp"
#include "gimm/io/nifti.hpp"
#include "gimm/io/png.hpp"

namespace {

std::uint8_t window(double hu, double lo, double hi) {
  return static_cast<std::uint8_t>(
      std::lround(255.0 * std::clamp((hu - lo) / (hi - lo), 0.0, 1.0)));
}

/// Axial slice k: rows = j (anterior at the top), cols = i (patient's left on the right).
gimm::Image<std::uint8_t> axial_slice(const gimm::Volume<std::int16_t>& hu, int k) {
  gimm::Image<std::uint8_t> img(hu.ny(), hu.nx());
  for (int j = 0; j < hu.ny(); ++j)
    for (int i = 0; i < hu.nx(); ++i) img(j, i) = window(hu(i, j, k), -200, 600);
  return img;
}

/// Coronal MIP over j: rows = k (head at the top), cols = i. Only the heart's depth range
/// (voxels within 70 mm of the centre line) so the spine does not hide the coronaries.
gimm::Image<std::uint8_t> coronal_mip(const gimm::Volume<std::int16_t>& hu) {
  gimm::Image<std::uint8_t> img(hu.nz(), hu.nx());
  for (int k = 0; k < hu.nz(); ++k)
    for (int i = 0; i < hu.nx(); ++i) {
      int best = -1024;
      for (int j = 0; j < hu.ny(); ++j) {
        const double y = hu.index_to_world(Eigen::Vector3d(i, j, k)).y();
        if (std::abs(y) < 70) best = std::max<int>(best, hu(i, j, k));
      }
      img(hu.nz() - 1 - k, i) = window(best, -200, 700);
    }
  return img;
}

/// The phantom's files at `base` + ".img.nii.gz", ".label.nii.gz", ".centerlines.json" and
/// with `preview` ".slice.png", ".mip.png".
void write_files(const gimm::Phantom& p, const gimm::PhantomOptions& options,
                 const nlohmann::json& centerlines, const std::filesystem::path& base,
                 bool preview) {
  gimm::write_nifti(base.string() + ".img.nii.gz", p.hu, "gimm phantom HU");
  gimm::write_nifti(base.string() + ".label.nii.gz", p.label, "gimm phantom coronary label");
  gimm::write_json_file(base.string() + ".centerlines.json", centerlines);
  if (preview) {
    const Eigen::Vector3d heart =
        gimm::phantom_grid(options.size)
            .world_to_index(p.anatomy.base_centre +
                            0.3 * p.anatomy.height_mm * p.anatomy.long_axis);
    const int k = std::clamp(static_cast<int>(std::lround(heart.z())), 0, p.hu.nz() - 1);
    gimm::write_png(base.string() + ".slice.png", axial_slice(p.hu, k));
    gimm::write_png(base.string() + ".mip.png", coronal_mip(p.hu));
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"gimm-phantom: a procedural CCTA patient (HU, coronary label, centerlines)",
               "gimm-phantom"};
  std::uint64_t seed = 0;
  std::string out_dir, size = "small", dominance = "auto", tree = "classic";
  double noise = 15.0;
  bool preview = false;
  gimm::LumenOptions lumen;
  app.add_option("--seed", seed, "patient seed")->required();
  app.add_option("--out", out_dir, "output directory (created if missing)")->required();
  app.add_option(
         "--size", size,
         "small (128x128x64) | imagecas (512x512x256) | chest (224x165x190, the whole chest)")
      ->check(CLI::IsMember({"small", "imagecas", "chest"}))
      ->capture_default_str();
  app.add_option("--dominance", dominance, "auto (seeded) | right | left | codominant")
      ->check(CLI::IsMember({"auto", "right", "left", "codominant"}))
      ->capture_default_str();
  app.add_option("--tree", tree, "classic | rich (side branches, Murray's-law calibres)")
      ->check(CLI::IsMember({"classic", "rich"}))
      ->capture_default_str();
  app.add_option("--noise", noise, "scanner noise sigma, HU")
      ->check(gimm::cli::in_range(0, 1000, true))
      ->capture_default_str();
  app.add_option("--stenoses", lumen.stenoses,
                 "focal stenoses (30-80% of the diameter, 4-12 mm) on that many main branches")
      ->check(CLI::Range(0, 8))
      ->capture_default_str();
  app.add_option("--lumen-irregularity", lumen.irregularity,
                 "sigma of the lumen's wavering along the vessels (0.05-0.1 look like "
                 "angiograms; 0: a smooth taper)")
      ->check(gimm::cli::in_range(0, 0.3, true))
      ->capture_default_str();
  gimm::TortuosityOptions tortuosity;
  app.add_option("--tortuosity", tortuosity.sigma_mm,
                 "mm: sd of the vessels' irregular sideways wander on the heart (over 4 mm "
                 "along them; 0: the classic course)")
      ->check(gimm::cli::in_range(0, 5, true))
      ->capture_default_str();
  app.add_flag("--preview", preview, "also write S.slice.png and S.mip.png");
  return gimm::cli::run(app, argc, argv, [&] {
    const auto t0 = std::chrono::steady_clock::now();
    gimm::PhantomOptions options;
    options.seed = seed;
    options.size = gimm::parse_phantom_size(size);
    options.dominance = gimm::parse_dominance(dominance);
    options.noise_hu = noise;
    options.tree = gimm::parse_tree_detail(tree);
    options.lumen = lumen;
    options.tortuosity = tortuosity;
    const gimm::Phantom p = gimm::make_phantom(options);
    const auto t1 = std::chrono::steady_clock::now();
    nlohmann::json centerlines = gimm::to_json(p.centerlines);
    centerlines["phantom"] = {{"seed", seed},
                              {"size", size},
                              {"dominance", gimm::to_string(p.anatomy.dominance)},
                              {"lumen_hu", p.anatomy.lumen_hu},
                              {"noise_hu", noise},
                              {"tree", tree},
                              {"heart_height_mm", p.anatomy.height_mm},
                              {"heart_radius_mm", p.anatomy.radius_mm}};
    if (!lumen.none())
      centerlines["phantom"]["lumen"] = gimm::lumen_json(lumen, p.anatomy.stenoses);
    if (!tortuosity.none())
      centerlines["phantom"]["tortuosity"] = gimm::tortuosity_json(tortuosity);
    if (options.size == gimm::PhantomSize::chest)
      centerlines["phantom"]["chest"] = {{"left_dome_z_mm", p.anatomy.left_dome_z},
                                         {"right_dome_z_mm", p.anatomy.right_dome_z},
                                         {"t1_top_z_mm", p.anatomy.t1_top_z}};
    const std::filesystem::path base = std::filesystem::path(out_dir) / std::to_string(seed);
    // All or nothing: written under a staging folder and moved into DIR at the end, so a failure
    // (a full disk) leaves DIR as it was (or absent).
    gimm::write_folder_all_or_nothing(out_dir, [&](const std::filesystem::path& staged) {
      write_files(p, options, centerlines, staged / std::to_string(seed), preview);
    });
    const auto t2 = std::chrono::steady_clock::now();
    auto ms = [](auto a, auto b) {
      return std::chrono::duration<double, std::milli>(b - a).count();
    };
    std::size_t labelled = 0;
    for (const auto v : p.label.storage()) labelled += v;
    std::printf(
        "gimm-phantom: seed %llu, %dx%dx%d, %s dominance, %zu branches, %.0f mm of "
        "centerline, %zu coronary voxels; generate %.0f ms, write %.0f ms -> %s.*\n",
        static_cast<unsigned long long>(seed), p.hu.nx(), p.hu.ny(), p.hu.nz(),
        gimm::to_string(p.anatomy.dominance), p.centerlines.branches.size(), p.centerlines.length(),
        labelled, ms(t0, t1), ms(t1, t2), base.string().c_str());
    return 0;
  });
}
