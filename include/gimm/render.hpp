#pragma once
/// The render room: ray-volume traversal (exact Siddon/Jacobs, trilinear) and the DRR renderer.
#include "gimm/render/drr.hpp"
#include "gimm/render/empty_space.hpp"
#include "gimm/render/ray_volume.hpp"
#include "gimm/render/siddon.hpp"
#include "gimm/render/trilinear.hpp"
