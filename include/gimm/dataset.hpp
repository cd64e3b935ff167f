#pragma once
/// The dataset room: the on-disk format of a gimm dataset, owned in one place (layout, the one
/// reader, the one writer, shards, resume and merge).
#include "gimm/dataset/layout.hpp"
#include "gimm/dataset/reader.hpp"
#include "gimm/dataset/run.hpp"
#include "gimm/dataset/writer.hpp"
