// Connected components (26-connectivity) and the LCA/RCA split on hand-made labels: left by
// patient position (LPS +x), specks dropped, and every refusal naming the label and the value.
#include <catch2/catch.hpp>

#include "gimm/anatomy/components.hpp"

using namespace gimm;

namespace {
/// A 20^3 label; direction flips the i axis when `flip_x` (world +x = -i), so "left" must come
/// from world coordinates, not from the index.
Volume<std::uint8_t> empty_label(bool flip_x = false) {
  VolumeGeometry g;
  g.dims = {20, 20, 20};
  if (flip_x) g.direction(0, 0) = -1;
  return Volume<std::uint8_t>(g, 0);
}
/// A straight rod of `length` voxels along k, plus a second row beside it (2 x length voxels).
void rod(Volume<std::uint8_t>& v, int i, int length, int j = 10) {
  for (int k = 2; k < 2 + length; ++k) v(i, j, k) = v(i, j + 1, k) = 1;
}
}  // namespace

TEST_CASE("Components: 26-connected voxels join, separated ones do not", "[anatomy][split]") {
  auto v = empty_label();
  v(1, 1, 1) = v(2, 2, 2) = 1;  // corner neighbours: one component
  v(5, 5, 5) = 1;               // two voxels apart: another
  const Components c = connected_components(v);
  CHECK(c.count() == 2);
}

TEST_CASE("Split: the component further to the patient's left is the LCA", "[anatomy][split]") {
  for (const bool flip : {false, true}) {
    auto v = empty_label(flip);
    rod(v, 3, 12);    // index i = 3
    rod(v, 16, 11);   // index i = 16
    v(10, 2, 2) = 1;  // a speck (< min_voxels) is dropped
    const auto split = split_coronary_systems(v);
    // Without the flip world x = i, so i = 16 is further left (+x); with it, i = 3 is.
    const int lca_i = flip ? 3 : 16, rca_i = flip ? 16 : 3;
    INFO("flip_x " << flip);
    CHECK(split.lca(lca_i, 10, 5) == 1);
    CHECK(split.rca(rca_i, 10, 5) == 1);
    CHECK(split.lca(rca_i, 10, 5) == 0);
    CHECK(split.lca(10, 2, 2) + split.rca(10, 2, 2) == 0);
  }
}

TEST_CASE("Split: bad labels are refused with the value and the name", "[anatomy][split]") {
  auto v = empty_label();
  CHECK_THROWS_WITH(split_coronary_systems(v, {}, "patient 9 label"),
                    Catch::Contains("patient 9 label: empty coronary mask"));
  rod(v, 3, 12);
  CHECK_THROWS_WITH(split_coronary_systems(v, {}, "patient 9 label"),
                    Catch::Contains("only one coronary component"));
  // The refusal names the option that accepts it (gimm-dataset shows its flag beside it).
  CHECK_THROWS_WITH(split_coronary_systems(v, {}, "patient 9 label"),
                    Catch::Contains("set SplitOptions::allow_single"));
  SplitOptions single;
  single.allow_single = true;
  single.heart_center_x = 10.0;  // the rod at x = 3 lies to the right of it: an RCA
  const auto split = split_coronary_systems(v, single);
  CHECK(split.rca_voxels == 24);
  CHECK(split.lca_voxels == 0);
  CHECK(split.components == 1);
  CHECK(split.dropped_voxels == 0);
  rod(v, 16, 9);
  v(0, 0, 0) = 2;
  CHECK_THROWS_WITH(split_coronary_systems(v, {}, "patient 9 label"),
                    Catch::Contains("must hold only 0 and 1, found 2"));
}

TEST_CASE("Split: what is left out is counted", "[anatomy][split]") {
  auto v = empty_label();
  rod(v, 3, 12);    // 24 voxels
  rod(v, 16, 11);   // 22 voxels
  rod(v, 10, 10);   // 20 voxels: a third tree, beyond the two largest
  v(6, 2, 17) = 1;  // a speck
  const auto split = split_coronary_systems(v);
  CHECK(split.components == 4);
  CHECK(split.label_voxels == 67);
  CHECK(split.lca_voxels + split.rca_voxels == 46);
  CHECK(split.dropped_voxels == 21);
  CHECK(split.dropped_fraction() == Approx(21.0 / 67.0));
  CHECK(CoronarySplit{}.dropped_fraction() == 0.0);
}
