// Fixture for layout_dependency_direction_catches (never compiled): the
// per-frame inference layer must not include the training data.
#include "gatcore/character/data/dataset.hpp"
#include "gatcore/character/features/features.hpp"
