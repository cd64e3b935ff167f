#pragma once
/// The io room (target gimm::io): JSON records, NIfTI, PNG, NPY.
#include "gimm/io/camera_json.hpp"
