#pragma once
// Fixture for layout_dependency_direction_catches: data/ may include rig/.
#include "gatcore/character/rig/skeleton.hpp"
