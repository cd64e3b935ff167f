// Every room's umbrella header compiles on its own and together (gimm/<room>.hpp).
#include <catch2/catch.hpp>

#include "gimm/anatomy.hpp"
#include "gimm/core.hpp"
#include "gimm/dataset.hpp"
#include "gimm/geometry.hpp"
#include "gimm/gimm.hpp"
#include "gimm/io.hpp"
#include "gimm/labels.hpp"
#include "gimm/match.hpp"
#include "gimm/metrics.hpp"
#include "gimm/nn.hpp"
#include "gimm/pipeline.hpp"
#include "gimm/render.hpp"
#include "gimm/render/vessel_mesh_projector.hpp"

TEST_CASE("umbrella headers: one pi, degrees both ways") {
  CHECK(gimm::deg_to_rad(180.0) == gimm::kPi);
  CHECK(gimm::rad_to_deg(gimm::kPi / 2) == Approx(90.0));
  CHECK(gimm::kPiOf<float> == static_cast<float>(gimm::kPi));
}
