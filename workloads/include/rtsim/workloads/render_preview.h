#pragma once
// A quick picture of a scene from a camera, traced with Embree and shaded by the
// geometric normal, so a person can see that a load is right.
#include <rtsim/workloads/image.h>
#include <rtsim/workloads/scene.h>

namespace rtsim {

// Front faces are shaded by |normal| colour, back faces tinted red so that a
// wrong winding shows at a glance; misses are dark grey.
Image render_preview(const Scene& scene, const Camera& camera, uint32_t width, uint32_t height);

}  // namespace rtsim
