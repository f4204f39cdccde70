#pragma once
#include <rtsim/workloads/scene.h>

namespace rtsim {

// Applies the load policy in place (see ValidationReport) and fills scene.validation.
// Also checks that materials, material ids and cameras are consistent; throws
// InputError naming the scene and the field when they are not, or when no
// triangle survives.
void validate_scene(Scene& scene);

}  // namespace rtsim
