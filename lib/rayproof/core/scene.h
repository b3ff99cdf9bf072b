// Scene files (docs/spec/scene.md) and the camera's pixel-to-ray mapping.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "rayproof/core/geometry.h"
#include "rayproof/core/mesh.h"
#include "rayproof/core/shapes.h"

namespace rayproof {

struct Camera {
  Vec3 eye;
  Vec3 forward, right, up;  // f, r = normalize(f × up), u = r × f
  int width = 0, height = 0;
  // The image window at distance 1 along `forward`: sx runs from window_left to window_right
  // across the image, sy from window_top to window_bottom down it (look-at cameras too).
  double window_left = 0, window_right = 0, window_top = 0, window_bottom = 0;
  // The ray of image point (x, y) in pixel units: pixel (i, j)'s centre is (i + ½, j + ½).
  Ray ray_through(double x, double y) const;
};

enum class Shading { flat, diffuse, depth };

struct PointLight {
  Vec3 position;
  double intensity = 1;
};

struct SceneObject {
  Shape shape;                       // unused when `mesh` is set
  std::shared_ptr<const Mesh> mesh;  // a "mesh" object (docs/spec/audit.md): its triangles, placed
  Vec3 color = Vec3(1, 1, 1);
  std::string id;
  std::string file;  // a mesh's file as the scene names it
};

struct Scene {
  Camera camera;
  Shading shading = Shading::flat;
  Vec3 background = Vec3::Zero();
  std::vector<PointLight> lights;
  std::vector<SceneObject> objects;
  double depth_near = 0, depth_far = 1;
  int samples = 1;                    // per pixel, a perfect square: a √n × √n grid of sub-pixel centres
  std::vector<std::string> warnings;  // e.g. degenerate mesh triangles skipped, naming the file
};

// Parses a scene; throws std::runtime_error naming the file and the field.
Scene parse_scene(const std::string& json_text, const std::string& file_name);
Scene load_scene(const std::string& path);

// The scene moved by `offset` (docs/spec/audit.md, headroom): camera eye, lights and every
// object, each coordinate rounded to double (a plane's offset becomes offset + n·by). Mesh
// triangles that the rounding makes degenerate are dropped and counted in `warnings`.
Scene translated(const Scene& scene, const Vec3& by);
// The scene scaled by 2^log2 about the origin (offsets.md's "moved by 2^k"): camera eye, lights
// and every object, exact in binary floating point unless a coordinate under- or overflows (a
// mesh triangle that becomes degenerate is then dropped and counted in `warnings`).
Scene scaled(const Scene& scene, int log2);

}  // namespace rayproof
