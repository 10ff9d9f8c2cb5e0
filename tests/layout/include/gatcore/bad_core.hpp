#pragma once
// Fixture for layout_dependency_direction_catches: the core (tensor, graph,
// models, ...) must not include the character pipeline.
#include "gatcore/character/rig/skeleton.hpp"
