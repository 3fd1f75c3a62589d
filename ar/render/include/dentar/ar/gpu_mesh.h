// A scene Mesh (scene_mesh.h) in GPU buffers, drawn with the layout
// position(3) normal(3) rgb(3) uv(2) floats at attribute locations 0..3.
// Needs a current GLES 3 context; move-only through its GL objects.
#pragma once

#include "dentar/ar/gl_objects.h"
#include "dentar/ar/scene_mesh.h"

namespace dentar::ar::scene {

struct GpuMesh {
  Buffer vbo, ibo;
  VertexArray vao;
  GLsizei count = 0;
};
GpuMesh upload(const Mesh& m);

}  // namespace dentar::ar::scene
