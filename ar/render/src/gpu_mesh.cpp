#include "dentar/ar/gpu_mesh.h"

#include <GLES3/gl3.h>

namespace dentar::ar::scene {

GpuMesh upload(const Mesh& m) {
  GpuMesh g;
  g.vbo = make_buffer();
  g.ibo = make_buffer();
  g.vao = make_vertex_array();
  glBindVertexArray(g.vao.id());
  glBindBuffer(GL_ARRAY_BUFFER, g.vbo.id());
  static_assert(sizeof(Vertex) == 11 * sizeof(float), "Vertex must be tightly packed floats");
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(m.vertices.size() * sizeof(Vertex)),
               m.vertices.data(), GL_STATIC_DRAW);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, g.ibo.id());
  glBufferData(GL_ELEMENT_ARRAY_BUFFER,
               static_cast<GLsizeiptr>(m.indices.size() * sizeof(std::uint32_t)), m.indices.data(),
               GL_STATIC_DRAW);
  const GLsizei stride = sizeof(Vertex);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(0));
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride,
                        reinterpret_cast<void*>(3 * sizeof(float)));
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, stride,
                        reinterpret_cast<void*>(6 * sizeof(float)));
  glEnableVertexAttribArray(3);
  glVertexAttribPointer(3, 2, GL_FLOAT, GL_FALSE, stride,
                        reinterpret_cast<void*>(9 * sizeof(float)));
  glBindVertexArray(0);
  g.count = static_cast<GLsizei>(m.indices.size());
  return g;
}


}  // namespace dentar::ar::scene
