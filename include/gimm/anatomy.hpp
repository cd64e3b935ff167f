#pragma once
/// The anatomy room: HU -> attenuation and contrast recipes, components and the LCA/RCA split,
/// centerlines, the isocentre rule, vessel meshes, the procedural phantom. Needs gimm::gimm
/// only; the centerlines' JSON record is the dataset room's (dataset/centerlines_json.hpp).
#include "gimm/anatomy/attenuation.hpp"
#include "gimm/anatomy/centerlines.hpp"
#include "gimm/anatomy/components.hpp"
#include "gimm/anatomy/coronary_system.hpp"
#include "gimm/anatomy/isocenter.hpp"
#include "gimm/anatomy/lumen.hpp"
#include "gimm/anatomy/phantom.hpp"
#include "gimm/anatomy/skeleton.hpp"
#include "gimm/anatomy/tortuosity.hpp"
#include "gimm/anatomy/vessel_mesh.hpp"
