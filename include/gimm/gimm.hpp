#pragma once
/// Everything in gimm that needs no optional dependency (Eigen, GLM, OpenMP only).
#include "gimm/core.hpp"
#include "gimm/geometry.hpp"
#include "gimm/version.hpp"
