// Mutation fuzzing of every reader that takes a file: NIfTI (.nii, .nii.gz), NRRD, MetaImage,
// PNG (8 and 16 bit), NPY, safetensors and matcher weights, camera, predictions and centerline
// JSON. Seeds are valid files (written by gimm's writers, or the committed fixtures); each
// iteration mutates one seed (bit flips, extreme integers over a header word, truncation,
// appended or repeated bytes) and reads it back.
//
// A reader may refuse a file with gimm::Error (or a subclass). Anything else is a defect: another
// exception type escaping (reported here, exit 1), or a crash, leak or undefined behaviour
// (reported by AddressSanitizer / UBSan, which this target is built with).
//
//   gimm_readers_fuzz [iterations per seed] [seed]      (ctest fuzz_readers: 400 1)
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "gimm/anatomy/centerlines_json.hpp"
#include "gimm/core/hash.hpp"
#include "gimm/core/rng.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/io/camera_json.hpp"
#include "gimm/io/files.hpp"
#include "gimm/io/nifti.hpp"
#include "gimm/io/npy.hpp"
#include "gimm/io/png.hpp"
#include "gimm/io/volume_file.hpp"
#include "gimm/match/matches.hpp"
#include "gimm/nn/matcher_file.hpp"
#include "gimm/nn/safetensors.hpp"

namespace fs = std::filesystem;

namespace {

struct Target {
  std::string name;
  std::vector<unsigned char> seed;
  std::string suffix;  ///< readers that pick the format by name need it
  std::function<void(const fs::path&)> read;
};

std::vector<unsigned char> bytes_of(const fs::path& p) {
  return gimm::read_file_bytes(p);
}

std::vector<Target> targets(const fs::path& dir) {
  std::vector<Target> t;
  const auto written = [&](const std::string& name, const std::function<void(const fs::path&)>& w) {
    const fs::path p = dir / ("seed_" + name);
    w(p);
    return bytes_of(p);
  };
  gimm::VolumeGeometry g;
  g.dims = {5, 4, 3};
  g.spacing = {0.7, 0.8, 1.5};
  gimm::Volume<float> vol(g, 0.0f);
  for (std::size_t i = 0; i < vol.size(); ++i) vol.data()[i] = float(i) - 20.0f;
  const auto read_nifti = [](const fs::path& p) { (void)gimm::read_nifti<float>(p); };
  t.push_back({"nifti", written("v.nii", [&](const fs::path& p) { gimm::write_nifti(p, vol); }),
               ".nii", read_nifti});
  t.push_back({"nifti_gz",
               written("v.nii.gz", [&](const fs::path& p) { gimm::write_nifti(p, vol); }),
               ".nii.gz", read_nifti});
  const fs::path fixtures = fs::path(GIMM_SOURCE_DIR) / "tests" / "data" / "volumes";
  const auto read_volume = [](const fs::path& p) { (void)gimm::read_volume<float>(p); };
  t.push_back({"nrrd", bytes_of(fixtures / "ct.nrrd"), ".nrrd", read_volume});
  t.push_back({"metaimage", bytes_of(fixtures / "ct.mha"), ".mha", read_volume});
  gimm::Image<std::uint8_t> im8(9, 7);
  gimm::Image<std::uint16_t> im16(6, 5);
  for (std::size_t i = 0; i < im8.size(); ++i) im8.data()[i] = std::uint8_t(i * 7);
  for (std::size_t i = 0; i < im16.size(); ++i) im16.data()[i] = std::uint16_t(i * 2000);
  const auto read_png = [](const fs::path& p) { (void)gimm::read_png_unit(p); };
  t.push_back({"png8", written("i8.png", [&](const fs::path& p) { gimm::write_png(p, im8); }),
               ".png", read_png});
  t.push_back({"png16", written("i16.png", [&](const fs::path& p) { gimm::write_png(p, im16); }),
               ".png", read_png});
  gimm::Image<float> imf(4, 6, 0.5f);
  t.push_back({"npy", written("f.npy", [&](const fs::path& p) { gimm::write_npy(p, imf); }), ".npy",
               [](const fs::path& p) { (void)gimm::read_npy_image<float>(p); }});
  const fs::path weights = fs::path(GIMM_SOURCE_DIR) / "tests" / "data" / "nn";
  t.push_back({"safetensors", bytes_of(weights / "parity_expected.safetensors"), ".safetensors",
               [](const fs::path& p) { (void)gimm::nn::SafetensorsFile::load(p.string()); }});
  t.push_back({"matcher", bytes_of(weights / "parity_weights.safetensors"), ".safetensors",
               [](const fs::path& p) { (void)gimm::nn::load_matcher(p.string()); }});
  gimm::CArm arm;
  arm.rows = arm.cols = 64;
  t.push_back(
      {"camera",
       written("c.json",
               [&](const fs::path& p) { gimm::write_json_file(p, gimm::to_json(arm.camera())); }),
       ".json", [](const fs::path& p) {
         (void)gimm::camera_from_json(gimm::read_json_file(p), p.string());
       }});
  gimm::PairMatches m;
  m.pair = "fuzz_readers/matches";  // the place it is read from: <folder>/<stem>
  m.add({1, 2}, {3, 4}, 0.5);
  m.add({5, 6}, {7, 8}, 0.25);
  t.push_back({"matches", written("m.json", [&](const fs::path& p) { gimm::write_matches(p, m); }),
               ".json", [](const fs::path& p) { (void)gimm::read_matches(p); }});
  gimm::CenterlineTree tree;
  gimm::CenterlineBranch b;
  b.name = "LAD";
  b.points = {{0, 0, 0}, {1, 2, 3}, {2, 4, 5}};
  b.radii = {1.5, 1.4, 1.2};
  tree.branches.push_back(b);
  t.push_back(
      {"centerlines",
       written("t.json", [&](const fs::path& p) { gimm::write_json_file(p, gimm::to_json(tree)); }),
       ".json", [](const fs::path& p) { (void)gimm::read_centerlines(p); }});
  return t;
}

/// One random mutation of `b` (never empty in, possibly empty out).
std::vector<unsigned char> mutate(std::vector<unsigned char> b, gimm::Rng& rng) {
  const int rounds = 1 + static_cast<int>(rng.below(3));
  for (int k = 0; k < rounds && !b.empty(); ++k) {
    const std::size_t at = rng.below(b.size());
    switch (rng.below(6)) {
      case 0:  // bit flips
        for (int f = 0; f < 1 + int(rng.below(4)); ++f)
          b[rng.below(b.size())] ^= std::uint8_t(1u << rng.below(8));
        break;
      case 1: {  // an extreme integer over a (header) word
        static const std::uint64_t words[] = {0,          1,          0x7f,       0x80,
                                              0xff,       0x7fffffff, 0x80000000, 0xffffffff,
                                              1ull << 62, ~0ull,      65536,      4294967297ull};
        const std::uint64_t w = words[rng.below(sizeof(words) / sizeof(words[0]))];
        const std::size_t width = rng.below(2) ? 4 : 8;
        for (std::size_t i = 0; i < width && at + i < b.size(); ++i)
          b[at + i] = std::uint8_t(w >> (8 * i));
        break;
      }
      case 2:  // truncation
        b.resize(at);
        break;
      case 3:  // random bytes appended
        for (int i = 0; i < 1 + int(rng.below(64)); ++i) b.push_back(std::uint8_t(rng.below(256)));
        break;
      case 4: {  // a chunk repeated
        const std::size_t len = std::min<std::size_t>(b.size() - at, 1 + rng.below(32));
        b.insert(b.begin() + long(at), b.begin() + long(at), b.begin() + long(at + len));
        break;
      }
      default:  // a digit or a JSON/text delimiter changed
        b[at] = std::uint8_t("0123456789-.e+{}[]\":, \n"[rng.below(23)]);
    }
  }
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  const int iterations = argc > 1 ? std::atoi(argv[1]) : 400;
  const std::uint64_t seed = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : 1;
  const fs::path dir = fs::path(GIMM_TEST_TMP) / "fuzz_readers";
  fs::remove_all(dir);
  fs::create_directories(dir);
  int defects = 0;
  for (const Target& t : targets(dir)) {
    gimm::Rng rng = gimm::Rng(seed).fork(gimm::stable_hash(t.name));
    int refused = 0;
    // The seed itself must read (a throw here ends the run: the harness is broken).
    const fs::path seed_path = dir / (t.name + t.suffix);
    gimm::write_file_atomic(seed_path, t.seed.data(), t.seed.size());
    t.read(seed_path);
    for (int i = 0; i < iterations; ++i) {
      const fs::path p = dir / (t.name + t.suffix);
      const std::vector<unsigned char> input = mutate(t.seed, rng);
      gimm::write_file_atomic(p, input.data(), input.size());
      try {
        t.read(p);
      } catch (const gimm::Error&) {
        ++refused;
      } catch (const std::exception& e) {
        ++defects;
        const fs::path keep = dir / ("defect_" + t.name + "_" + std::to_string(i) + t.suffix);
        fs::copy_file(p, keep, fs::copy_options::overwrite_existing);
        std::fprintf(stderr,
                     "%s: iteration %d: a non-gimm exception escaped: %s (input kept: %s)\n",
                     t.name.c_str(), i, e.what(), keep.c_str());
      }
    }
    std::printf("%-12s %d inputs, %d refused with gimm::Error, the rest read\n", t.name.c_str(),
                iterations, refused);
  }
  std::printf("readers_fuzz: %d defects\n", defects);
  return defects == 0 ? 0 : 1;
}
