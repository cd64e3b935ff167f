// core/huge_pages.hpp: big buffers advised onto transparent huge pages before their first touch.
// The helpers must keep a vector's contents and size whatever the kernel does with the advice;
// where the kernel takes the advice (transparent_hugepage "madvise" or "always"), a touched
// buffer must show huge pages in /proc/self/smaps, or the advice is not reaching it.
#include <catch2/catch.hpp>
#include <cstdint>
#include <fstream>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

#include "gimm/core/huge_pages.hpp"
#include "gimm/core/volume.hpp"

namespace {

/// The kernel's transparent huge page mode: "always", "madvise", "never", or "" (no THP).
std::string thp_mode() {
  std::ifstream in("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string line;
  std::getline(in, line);
  const auto open = line.find('['), close = line.find(']');
  return open == std::string::npos || close == std::string::npos
             ? ""
             : line.substr(open + 1, close - open - 1);
}

/// kB of huge pages in the mapping of /proc/self/smaps that holds `address`; -1 if none does.
long huge_kb_at(const void* address) {
  std::ifstream smaps("/proc/self/smaps");
  const auto at = reinterpret_cast<std::uintptr_t>(address);
  bool inside = false;
  for (std::string line; std::getline(smaps, line);) {
    std::uintptr_t begin = 0, end = 0;
    char dash = 0;
    std::istringstream head(line);
    if (head >> std::hex >> begin >> dash >> end && dash == '-') {
      inside = at >= begin && at < end;
      continue;
    }
    if (inside && line.rfind("AnonHugePages:", 0) == 0)
      return std::stol(line.substr(line.find(':') + 1));
  }
  return -1;
}

}  // namespace

TEST_CASE("reserve_huge and resize_huge keep the contents and size", "[core][huge_pages]") {
  std::vector<int> v(1000);
  std::iota(v.begin(), v.end(), 0);
  const std::size_t big = (gimm::kHugePageAdviceMinBytes / sizeof(int)) * 2;
  gimm::reserve_huge(v, big);
  CHECK(v.size() == 1000u);
  CHECK(v.capacity() >= big);
  CHECK(v[0] == 0);
  CHECK(v[999] == 999);
  const int* storage = v.data();
  gimm::reserve_huge(v, 10);  // smaller than the capacity: nothing moves
  CHECK(v.data() == storage);
  gimm::resize_huge(v, big + 5);
  CHECK(v.size() == big + 5);
  CHECK(v[999] == 999);
  CHECK(v[1000] == 0);  // value-initialised, as resize()
  CHECK(v[big + 4] == 0);
}

TEST_CASE("advise_huge_pages leaves small buffers and null alone", "[core][huge_pages]") {
  std::vector<char> small(gimm::kHugePageAdviceMinBytes - 1);
  CHECK_FALSE(gimm::advise_huge_pages(small.data(), small.size()));
  CHECK_FALSE(gimm::advise_huge_pages(nullptr, std::size_t{1} << 30));
}

TEST_CASE("a volume's voxels land on huge pages where the kernel offers them",
          "[core][huge_pages]") {
  const std::string mode = thp_mode();
  gimm::VolumeGeometry g;
  g.dims = {256, 256, 64};  // 16 MB of float
  const gimm::Volume<float> volume(g, 1.0f);
  if (mode != "madvise" && mode != "always") {
    WARN("transparent huge pages are '" << mode << "' here: the advice cannot be checked");
    return;
  }
  // The middle of the buffer lies in its 2 MB-aligned part, which was advised and touched.
  const long kb = huge_kb_at(volume.data() + volume.size() / 2);
  INFO("THP mode " << mode << ", AnonHugePages of the volume's mapping: " << kb << " kB");
  CHECK(kb > 0);
}
