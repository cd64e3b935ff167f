#pragma once
/// The labels room: the clinical view protocol and the per-view and per-pair 3D-2D labels.
#include "gimm/labels/correspondence.hpp"
#include "gimm/labels/view_list.hpp"
#include "gimm/labels/view_protocol.hpp"
#include "gimm/labels/views.hpp"
