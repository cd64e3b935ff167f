// gimm-centerlines: 3D centerlines of a coronary label, per system, as JSON; optionally
// compared with a ground-truth tree (the phantom's S.centerlines.json).
//   gimm-centerlines --label L.nii.gz|.nrrd|.mha --out TREE.json [--truth S.centerlines.json]
//                    [--tolerance MM] [--min-spur MM]
#include <chrono>
#include <cstdio>
#include <optional>

#include "cli_common.hpp"
#include "gimm/anatomy/components.hpp"
#include "gimm/anatomy/skeleton.hpp"
#include "gimm/dataset/centerlines_json.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/volume_file.hpp"

int main(int argc, char** argv) {
  CLI::App app{"gimm-centerlines: coronary centerlines (LCA and RCA) of a label volume",
               "gimm-centerlines"};
  std::string label_path, out_path, truth_path;
  double tolerance = 1.5;
  gimm::SkeletonOptions options;
  app.add_option(
         "--label", label_path,
         "coronary label (0/1): NIfTI .nii/.nii.gz, NRRD .nrrd/.nhdr or MetaImage .mha/.mhd")
      ->required()
      ->check(CLI::ExistingPath);  // a folder gets read_volume's advice on converting it
  app.add_option("--out", out_path, "output centerlines JSON")->required();
  app.add_option("--truth", truth_path, "ground-truth centerlines JSON to compare with")
      ->check(CLI::ExistingFile);
  app.add_option("--tolerance", tolerance, "distance (mm) counted as agreement")
      ->check(gimm::cli::Positive)
      ->capture_default_str();
  app.add_option("--min-spur", options.min_spur_mm, "spurs shorter than this (mm) are pruned")
      ->check(gimm::cli::at_least(0))
      ->capture_default_str();
  return gimm::cli::run(app, argc, argv, [&] {
    GIMM_USAGE_CHECK(app.count("--tolerance") == 0 || !truth_path.empty(),
                     "--tolerance is for the comparison with --truth; give --truth too");
    auto inputs = gimm::cli::volume_input("--label", label_path);
    inputs.push_back({"--truth", truth_path});
    gimm::cli::refuse_outputs_over_inputs({{"--out", out_path}}, inputs);
    // The truth is read first: a bad --truth fails the run before --out is written.
    std::optional<gimm::CenterlineTree> truth;
    if (!truth_path.empty()) truth = gimm::read_centerlines(truth_path);
    const auto t0 = std::chrono::steady_clock::now();
    if (const std::string note = gimm::detached_data_note(label_path); !note.empty())
      std::cerr << "gimm-centerlines: note: " << note << "\n";
    const auto label = gimm::read_volume<std::uint8_t>(label_path);
    const auto split = gimm::split_coronary_systems(label, {}, label_path);
    const auto t1 = std::chrono::steady_clock::now();
    gimm::CenterlineTree tree;
    for (const auto system : {gimm::CoronarySystem::LCA, gimm::CoronarySystem::RCA}) {
      options.system = system;
      const auto& mask = system == gimm::CoronarySystem::LCA ? split.lca : split.rca;
      auto part = gimm::extract_centerlines(mask, options, label_path);
      const int shift = static_cast<int>(tree.branches.size());
      for (auto& b : part.branches) {
        if (b.parent >= 0) b.parent += shift;
        tree.branches.push_back(std::move(b));
      }
    }
    const auto t2 = std::chrono::steady_clock::now();
    gimm::write_json_file(out_path, gimm::to_json(tree));
    auto ms = [](auto a, auto b) {
      return std::chrono::duration<double, std::milli>(b - a).count();
    };
    std::printf(
        "gimm-centerlines: %zu branches, LCA %.0f mm, RCA %.0f mm; read+split %.0f ms, "
        "centerlines %.0f ms -> %s\n",
        tree.branches.size(), tree.length(int(gimm::CoronarySystem::LCA)),
        tree.length(int(gimm::CoronarySystem::RCA)), ms(t0, t1), ms(t1, t2), out_path.c_str());
    if (truth) {
      const auto c = gimm::compare_centerlines(tree, *truth, tolerance);
      std::printf(
          "against %s (tolerance %.2f mm): mean distance %.3f mm (extracted->truth), "
          "%.3f mm (truth->extracted); spurious %.1f of %.1f mm (%.1f%%); missed %.1f of "
          "%.1f mm (%.1f%%)\n",
          truth_path.c_str(), tolerance, c.mean_distance_mm, c.mean_truth_distance_mm,
          c.spurious_length_mm, c.extracted_length_mm,
          100 * c.spurious_length_mm / std::max(1e-9, c.extracted_length_mm), c.missed_length_mm,
          c.truth_length_mm, 100 * c.missed_length_mm / std::max(1e-9, c.truth_length_mm));
    }
    return 0;
  });
}
