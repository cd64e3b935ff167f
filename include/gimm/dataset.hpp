#pragma once
/// The dataset room: the on-disk format of a gimm dataset, owned in one place (layout, the one
/// reader, the one writer, shards, resume and merge) and its JSON records of a patient's
/// centerline tree and of each view's image formation.
#include "gimm/dataset/centerlines_json.hpp"
#include "gimm/dataset/formation_json.hpp"
#include "gimm/dataset/layout.hpp"
#include "gimm/dataset/reader.hpp"
#include "gimm/dataset/run.hpp"
#include "gimm/dataset/writer.hpp"
