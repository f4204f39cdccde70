#pragma once
#include <rtsim/workloads/scene.h>

namespace rtsim {

// Applies the load policy in place (see ValidationReport) and fills scene.validation
// (keeping the loader's dropped_sky_faces and dropped_tool_faces).
// Also checks that materials, material ids and cameras are consistent; throws
// InputError naming the scene and the field when they are not, or when no
// triangle survives. An instanced scene: its meshes must cover the triangles in
// order, each instance must name a mesh and have a finite, affine, invertible
// transform (InputError naming the instance), and no instance may reach past
// kMaxSceneCoordinate; triangles are checked in object space, an index outside its
// own mesh's vertices counts as a bad index, and dropping keeps the meshes' ranges
// over their surviving triangles (the report counts unique triangles).
void validate_scene(Scene& scene);

}  // namespace rtsim
