// Fixture for layout_dependency_direction_catches: the runtime (what an
// engine links) must not include the trainer.
#include "gatcore/models/train.hpp"
