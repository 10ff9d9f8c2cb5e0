#pragma once
// Fixture for layout_dependency_direction_catches: a header outside any layer.
