#pragma once
// Fixture for layout_dependency_direction_catches: rig (the bottom layer)
// including data/ must be reported.
#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/rig/skeleton.hpp"
