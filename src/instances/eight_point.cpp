// The costly double instance of gimm/geometry/eight_point.hpp (a 9x9 eigensolver), compiled once
// for gimm's own binaries; the header declares it extern under GIMM_EXTERN_INSTANCES
// (docs/performance.md, "Build").
#include "gimm/geometry/eight_point.hpp"

namespace gimm {
GIMM_EIGHT_POINT_INSTANCES()
}  // namespace gimm
