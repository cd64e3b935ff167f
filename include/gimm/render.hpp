#pragma once
/// The render room: ray-volume traversal (exact Siddon/Jacobs, trilinear), empty-space skipping,
/// axial pads, the DRR renderer, the prepared view renderer, and image formation (iodine,
/// collimator shutters, the acquisition and processing chain). The Embree vessel-mesh projector
/// (render/vessel_mesh_projector.hpp, target gimm::embree) is included on its own; the image
/// formation's JSON record is the dataset room's (dataset/formation_json.hpp).
#include "gimm/render/angiogram_formation.hpp"
#include "gimm/render/axial_pad.hpp"
#include "gimm/render/collimator.hpp"
#include "gimm/render/drr.hpp"
#include "gimm/render/empty_space.hpp"
#include "gimm/render/image_degradation.hpp"
#include "gimm/render/iodine.hpp"
#include "gimm/render/padded_attenuation.hpp"
#include "gimm/render/ray_volume.hpp"
#include "gimm/render/siddon.hpp"
#include "gimm/render/trilinear.hpp"
#include "gimm/render/vessel_surface.hpp"
#include "gimm/render/view_renderer.hpp"
