#pragma once
/// The geometry room: C-arm cameras, epipolar geometry, F estimation, gating, triangulation,
/// a pair aligned to landmarks.
#include "gimm/geometry/camera.hpp"
#include "gimm/geometry/camera_error.hpp"
#include "gimm/geometry/carm.hpp"
#include "gimm/geometry/correspondences.hpp"
#include "gimm/geometry/eight_point.hpp"
#include "gimm/geometry/epipolar.hpp"
#include "gimm/geometry/fundamental.hpp"
#include "gimm/geometry/gate_options.hpp"
#include "gimm/geometry/gating.hpp"
#include "gimm/geometry/landmark_alignment.hpp"
#include "gimm/geometry/triangulation.hpp"
#include "gimm/geometry/two_rays.hpp"
