// PLY and OBJ writers for the welded tooth surface. Files use millimetres
// (the user boundary); the layout is documented in docs/formats.md.
#include <algorithm>
#include <bit>
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <type_traits>

#include "dentar/volume/material.h"
#include "dentar/volume/surface.h"

namespace dentar::volume {
namespace {

constexpr double kMmPerM = 1000.0;

struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f) std::fclose(f);
  }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

Error io_error(const char* fn, const std::string& path, const char* what, int err) {
  std::string msg = std::string(fn) + ": " + what + " '" + path + "'";
  if (err != 0) msg += std::string(": ") + std::strerror(err);
  return Error{std::move(msg)};
}

// Writes buf, closes the file and reports any failure (a full disk shows up
// at fwrite or fclose).
Status write_and_close(File f, const std::string& buf, const char* fn, const std::string& path) {
  errno = 0;
  if (std::fwrite(buf.data(), 1, buf.size(), f.get()) != buf.size())
    return io_error(fn, path, "cannot write", errno);
  errno = 0;
  if (std::fclose(f.release()) != 0) return io_error(fn, path, "cannot finish writing", errno);
  return {};
}

Result<File> open_for_writing(const char* fn, const std::string& path, const char* mode) {
  errno = 0;
  File f(std::fopen(path.c_str(), mode));
  if (!f) return io_error(fn, path, "cannot open for writing", errno);
  return f;
}

template <typename T>
void put_le(std::string& buf, T v) {
  static_assert(std::is_trivially_copyable_v<T>);
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(b, b + sizeof(T));
  buf.append(b, sizeof(T));
}

float to_mm(float m) { return static_cast<float>(static_cast<double>(m) * kMmPerM); }

void put_float_text(std::string& buf, float v) {
  char tmp[32];
  // Shortest representation that reads back to the same float.
  const auto r = std::to_chars(tmp, tmp + sizeof(tmp), v);
  buf.append(tmp, r.ptr);
}

void put_uint_text(std::string& buf, std::uint64_t v) {
  char tmp[24];
  const auto r = std::to_chars(tmp, tmp + sizeof(tmp), v);
  buf.append(tmp, r.ptr);
}

}  // namespace

Status write_ply(const TriangleMesh& mesh, const std::string& path) {
  constexpr const char* kFn = "dentar::volume::write_ply";
  if (mesh.vertices.size() > 0x7fffffffu)
    return Error{std::string(kFn) + ": too many vertices for PLY int indices, '" + path + "'"};
  auto f = open_for_writing(kFn, path, "wb");
  if (!f) return Error{f.error()};

  std::string buf;
  buf.reserve(512 + mesh.vertices.size() * 27 + mesh.triangle_count() * 13);
  buf += "ply\nformat binary_little_endian 1.0\n";
  buf += "comment DentAR tooth surface, tooth frame, millimetres\n";
  buf += "element vertex " + std::to_string(mesh.vertices.size()) + "\n";
  buf +=
      "property float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  buf += "element face " + std::to_string(mesh.triangle_count()) + "\n";
  buf += "property list uchar int vertex_indices\nend_header\n";
  for (const MeshVertex& v : mesh.vertices) {
    for (int a = 0; a < 3; ++a) put_le(buf, to_mm(v.position_m[a]));
    for (int a = 0; a < 3; ++a) put_le(buf, v.normal[a]);
    const auto& rgb = material_info(v.material & (kMaxMaterials - 1)).rgb;
    buf.append(reinterpret_cast<const char*>(rgb.data()), 3);
  }
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    put_le(buf, std::uint8_t{3});
    for (int k = 0; k < 3; ++k) put_le(buf, static_cast<std::int32_t>(mesh.indices[3 * t + k]));
  }
  return write_and_close(std::move(f.value()), buf, kFn, path);
}

Status write_obj(const TriangleMesh& mesh, const std::string& path) {
  constexpr const char* kFn = "dentar::volume::write_obj";
  auto f = open_for_writing(kFn, path, "wb");
  if (!f) return Error{f.error()};

  std::string buf;
  buf.reserve(64 + mesh.vertices.size() * 80 + mesh.triangle_count() * 40);
  buf += "# DentAR tooth surface, tooth frame, millimetres\n";
  buf += "# vertices " + std::to_string(mesh.vertices.size()) + ", triangles " +
         std::to_string(mesh.triangle_count()) + "\n";
  for (const MeshVertex& v : mesh.vertices) {
    buf += "v";
    for (int a = 0; a < 3; ++a) {
      buf += ' ';
      put_float_text(buf, to_mm(v.position_m[a]));
    }
    buf += '\n';
  }
  for (const MeshVertex& v : mesh.vertices) {
    buf += "vn";
    for (int a = 0; a < 3; ++a) {
      buf += ' ';
      put_float_text(buf, v.normal[a]);
    }
    buf += '\n';
  }
  for (std::size_t t = 0; t < mesh.triangle_count(); ++t) {
    buf += 'f';
    for (int k = 0; k < 3; ++k) {
      const std::uint64_t i = std::uint64_t{mesh.indices[3 * t + k]} + 1;  // OBJ is 1-based
      buf += ' ';
      put_uint_text(buf, i);
      buf += "//";
      put_uint_text(buf, i);
    }
    buf += '\n';
  }
  return write_and_close(std::move(f.value()), buf, kFn, path);
}

}  // namespace dentar::volume
