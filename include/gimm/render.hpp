#pragma once
/// The render room: ray-volume traversal (exact Siddon/Jacobs, trilinear), empty-space skipping,
/// axial pads, the DRR renderer and the prepared view renderer. The Embree vessel-mesh projector
/// (render/vessel_mesh_projector.hpp, target gimm::embree) is included on its own.
#include "gimm/render/axial_pad.hpp"
#include "gimm/render/drr.hpp"
#include "gimm/render/empty_space.hpp"
#include "gimm/render/padded_attenuation.hpp"
#include "gimm/render/ray_volume.hpp"
#include "gimm/render/siddon.hpp"
#include "gimm/render/trilinear.hpp"
#include "gimm/render/vessel_surface.hpp"
#include "gimm/render/view_renderer.hpp"
