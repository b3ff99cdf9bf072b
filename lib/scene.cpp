#include "rayproof/core/scene.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "rayproof/core/json_fields.h"

namespace rayproof {

Ray Camera::ray_through(double x, double y) const {
  // scene.md: sx = left + x/W·(right − left), sy = top + y/H·(bottom − top); the look-at form
  // is the window left = −tan(fov/2)·W/H, right = −left, top = tan(fov/2), bottom = −top.
  const double sx = window_left + x / width * (window_right - window_left);
  const double sy = window_top + y / height * (window_bottom - window_top);
  return Ray{eye, forward + sx * right + sy * up};
}

namespace {

int read_positive_int(const json& j, const std::string& field, int max) {
  const double x = read_number(j, field);
  if (x != std::floor(x) || x < 1 || x > max)
    throw FieldError(field, "expected an integer in 1.." + std::to_string(max));
  return static_cast<int>(x);
}

Vec3 read_color(const json& j, const std::string& field) {
  Vec3 c = read_vec3(j, field);
  for (int i = 0; i < 3; ++i)
    if (c[i] < 0) throw FieldError(field, "colour components must be >= 0");
  return c;
}

Camera read_camera(const json& j) {
  const bool window = j.is_object() && j.contains("left");
  if (window)
    check_keys(j, "camera", {"eye", "left", "right", "top", "bottom", "look_at", "up", "width", "height"},
               {"eye", "left", "right", "top", "bottom", "width", "height"});
  else
    check_keys(j, "camera", {"eye", "look_at", "up", "fov_deg", "width", "height"},
               {"eye", "look_at", "up", "fov_deg", "width", "height"});
  Camera cam;
  cam.eye = read_vec3(j["eye"], "camera.eye");
  const Vec3 look_at =
      j.contains("look_at") ? read_vec3(j["look_at"], "camera.look_at") : Vec3(cam.eye + Vec3(0, 0, 1));
  const Vec3 up = j.contains("up") ? read_vec3(j["up"], "camera.up") : Vec3(0, 1, 0);
  cam.width = read_positive_int(j["width"], "camera.width", 16384);
  cam.height = read_positive_int(j["height"], "camera.height", 16384);
  const Vec3 view = look_at - cam.eye;
  // hypot, not sqrt(dot): a look_at 1e154 away is a finite distance whose square overflows.
  const double view_length = std::hypot(view.x(), view.y(), view.z());
  if (!(view_length > 0) || !std::isfinite(view_length))
    throw FieldError("camera.look_at", "must differ from eye by a finite, non-zero distance");
  cam.forward = view / view_length;
  const Vec3 side = cross(cam.forward, up);
  const double side_length = std::hypot(side.x(), side.y(), side.z());
  if (!(side_length > 0) || !std::isfinite(side_length))
    throw FieldError("camera.up", "must be finite and not parallel to the view direction");
  cam.right = side / side_length;
  cam.up = cross(cam.right, cam.forward);
  if (window) {
    cam.window_left = read_number(j["left"], "camera.left");
    cam.window_right = read_number(j["right"], "camera.right");
    cam.window_top = read_number(j["top"], "camera.top");
    cam.window_bottom = read_number(j["bottom"], "camera.bottom");
    if (!(cam.window_left < cam.window_right)) throw FieldError("camera.right", "must be greater than left");
    if (cam.window_top == cam.window_bottom) throw FieldError("camera.bottom", "must differ from top");
  } else {
    const double fov = read_number(j["fov_deg"], "camera.fov_deg");
    if (!(fov > 0 && fov < 180)) throw FieldError("camera.fov_deg", "must be in (0, 180)");
    const double half = std::tan(fov * std::numbers::pi / 360);
    const double aspect = static_cast<double>(cam.width) / cam.height;
    cam.window_left = -half * aspect;
    cam.window_right = half * aspect;
    cam.window_top = half;
    cam.window_bottom = -half;
  }
  // Every ray the camera makes must be finite (the exact oracle cannot hold ∞). A direction is
  // forward + sx·right + sy·up with unit vectors and sx between left and right (sy between top
  // and bottom, each rounded by at most 2u), so each component is at most 1 + max|sx| + max|sy|:
  // refuse when that, or the window's width or height, is not comfortably finite.
  const double widest = std::max(std::abs(cam.window_left), std::abs(cam.window_right));
  const double tallest = std::max(std::abs(cam.window_top), std::abs(cam.window_bottom));
  constexpr double kLargest = std::numeric_limits<double>::max() / 4;
  if (!(std::abs(cam.window_right - cam.window_left) <= kLargest &&
        std::abs(cam.window_bottom - cam.window_top) <= kLargest && 1 + widest + tallest <= kLargest))
    throw FieldError(window ? "camera.right" : "camera.fov_deg",
                     "the window is so wide that ray directions would overflow (every camera ray must be finite)");
  return cam;
}

// A "mesh" object: the file is relative to the scene file's folder.
SceneObject read_mesh_object(const json& j, const std::string& field, const std::string& scene_dir,
                             std::vector<std::string>& warnings) {
  check_keys(j, field, {"type", "file", "color", "id", "scale", "translate"}, {"type", "file"});
  if (!j["file"].is_string() || j["file"].get<std::string>().empty())
    throw FieldError(field + ".file", "expected a file name");
  SceneObject obj;
  obj.file = j["file"];
  const double scale = j.contains("scale") ? read_number(j["scale"], field + ".scale") : 1.0;
  if (!(scale != 0)) throw FieldError(field + ".scale", "must be non-zero");
  const Vec3 translate = j.contains("translate") ? read_vec3(j["translate"], field + ".translate") : Vec3(Vec3::Zero());
  const std::string path = obj.file.front() == '/' || scene_dir.empty() ? obj.file : scene_dir + "/" + obj.file;
  try {
    obj.mesh = std::make_shared<const Mesh>(load_mesh(path, scale, translate));
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(std::string(e.what()) + " (" + field + ".file)");
  }
  if (obj.mesh->degenerate_skipped > 0)
    warnings.push_back(printable(path) + ": " + std::to_string(obj.mesh->degenerate_skipped) +
                       " degenerate (exactly collinear) triangles skipped");
  return obj;
}

Scene read_scene(const json& j, const std::string& scene_dir) {
  check_keys(j, "", {"camera", "shading", "background", "lights", "objects", "depth", "samples"},
             {"camera", "objects"});
  Scene scene;
  scene.camera = read_camera(j["camera"]);
  if (j.contains("shading")) {
    if (!j["shading"].is_string()) throw FieldError("shading", "expected a string");
    const std::string s = j["shading"];
    if (s == "flat")
      scene.shading = Shading::flat;
    else if (s == "diffuse")
      scene.shading = Shading::diffuse;
    else if (s == "depth")
      scene.shading = Shading::depth;
    else
      throw FieldError("shading", "unknown shading \"" + s + "\" (flat, diffuse, depth)");
  }
  if (j.contains("background")) scene.background = read_color(j["background"], "background");
  if (j.contains("lights")) {
    const json& lights = j["lights"];
    if (!lights.is_array()) throw FieldError("lights", "expected an array");
    for (size_t i = 0; i < lights.size(); ++i) {
      const std::string f = "lights[" + std::to_string(i) + "]";
      check_keys(lights[i], f, {"type", "position", "intensity"}, {"type", "position"});
      if (lights[i]["type"] != "point") throw FieldError(f + ".type", "only \"point\" lights exist");
      PointLight light{read_vec3(lights[i]["position"], f + ".position"), 1};
      if (lights[i].contains("intensity")) {
        light.intensity = read_number(lights[i]["intensity"], f + ".intensity");
        if (light.intensity < 0) throw FieldError(f + ".intensity", "must be >= 0");
      }
      scene.lights.push_back(light);
    }
  }
  const json& objects = j["objects"];
  if (!objects.is_array()) throw FieldError("objects", "expected an array");
  for (size_t i = 0; i < objects.size(); ++i) {
    const std::string f = "objects[" + std::to_string(i) + "]";
    SceneObject obj;
    const bool is_mesh = objects[i].is_object() && objects[i].contains("type") && objects[i]["type"] == "mesh";
    if (is_mesh)
      obj = read_mesh_object(objects[i], f, scene_dir, scene.warnings);
    else
      obj.shape = read_shape(objects[i], f, {"color", "id"});
    if (objects[i].contains("color")) obj.color = read_color(objects[i]["color"], f + ".color");
    if (objects[i].contains("id")) {
      if (!objects[i]["id"].is_string()) throw FieldError(f + ".id", "expected a string");
      obj.id = objects[i]["id"];
    }
    scene.objects.push_back(std::move(obj));
  }
  if (scene.shading == Shading::depth) {
    if (!j.contains("depth")) throw FieldError("depth", "depth shading needs {\"near\": .., \"far\": ..}");
    check_keys(j["depth"], "depth", {"near", "far"}, {"near", "far"});
    scene.depth_near = read_number(j["depth"]["near"], "depth.near");
    scene.depth_far = read_number(j["depth"]["far"], "depth.far");
    if (!(scene.depth_near < scene.depth_far)) throw FieldError("depth.far", "must be greater than near");
  } else if (j.contains("depth")) {
    check_keys(j["depth"], "depth", {"near", "far"}, {});
  }
  if (j.contains("samples")) {
    scene.samples = read_positive_int(j["samples"], "samples", 1024);
    const int k = static_cast<int>(std::lround(std::sqrt(scene.samples)));
    if (k * k != scene.samples) throw FieldError("samples", "must be a perfect square (1, 4, 9, ...)");
  }
  return scene;
}

// The 1-based line of a byte offset, for JSON syntax errors.
long line_of(const std::string& text, size_t byte) {
  long line = 1;
  for (size_t i = 0; i < byte && i < text.size(); ++i) line += text[i] == '\n';
  return line;
}

}  // namespace

Scene parse_scene(const std::string& text, const std::string& file_name) {
  const std::string file = printable(file_name);
  try {
    const size_t slash = file_name.find_last_of('/');
    return read_scene(parse_json_text(text), slash == std::string::npos ? "." : file_name.substr(0, slash));
  } catch (const json::parse_error& e) {
    throw std::runtime_error(file + ":" + std::to_string(line_of(text, e.byte)) + ": malformed JSON: " + e.what());
  } catch (const FieldError& e) {
    // Name the line too when the field's key occurs exactly once in the file (JSON values
    // carry no positions, and a guess between several occurrences would mislead).
    std::string key = e.field.substr(e.field.find_last_of('.') + 1);
    key = "\"" + key.substr(0, key.find('[')) + "\"";
    const size_t at = text.find(key);
    const bool unique = at != std::string::npos && text.find(key, at + 1) == std::string::npos;
    const std::string where = unique ? ":" + std::to_string(line_of(text, at)) : "";
    throw std::runtime_error(file + where + ": field '" + printable(e.field) + "': " + printable(e.what()));
  }
}

Scene load_scene(const std::string& path) {
  // "-" is standard input, as for every input (README); its meshes are relative to the
  // working directory.
  const std::string name = path == "-" ? "(standard input)" : printable(path);
  std::ifstream file;
  if (path != "-") {
    file.open(path, std::ios::binary);
    if (!file) throw std::runtime_error(name + ": cannot open file");
  }
  std::stringstream buf;
  buf << (path == "-" ? std::cin.rdbuf() : file.rdbuf());
  if (buf.str().find_first_not_of(" \t\r\n") == std::string::npos) throw std::runtime_error(name + ": empty file");
  return parse_scene(buf.str(), path == "-" ? name : path);
}

namespace {
// The scene with every point moved by `point` (camera eye, lights, mesh vertices) and every other
// shape by `shape`, each coordinate rounded to double; mesh triangles the move makes degenerate
// are dropped and counted in `warnings` (`how` says which move: "translated", "scaled").
template <class Point, class MoveShape>
Scene moved(const Scene& scene, Point point, MoveShape shape, const char* how) {
  Scene out = scene;
  out.warnings.clear();
  out.camera.eye = point(scene.camera.eye);
  for (PointLight& light : out.lights) light.position = point(light.position);
  for (SceneObject& obj : out.objects) {
    if (!obj.mesh) {
      shape(obj.shape);
      continue;
    }
    auto mesh = std::make_shared<Mesh>();
    mesh->vertex_count = obj.mesh->vertex_count;
    for (size_t e = 0; e < obj.mesh->triangles.size(); ++e) {
      Triangle tri = obj.mesh->triangles[e];
      for (Vec3& v : tri.v) v = point(v);
      if (degenerate_reason(tri)) {
        ++mesh->degenerate_skipped;
        continue;
      }
      mesh->triangles.push_back(tri);
      mesh->corners.push_back(obj.mesh->corners[e]);
    }
    if (mesh->degenerate_skipped > 0)
      out.warnings.push_back(obj.file + ": " + std::to_string(mesh->degenerate_skipped) +
                             " triangles became degenerate when " + how + " and were dropped");
    obj.mesh = std::move(mesh);
  }
  return out;
}
}  // namespace

Scene scaled(const Scene& scene, int log2) {
  return moved(
      scene,
      [log2](const Vec3& v) { return Vec3(std::ldexp(v.x(), log2), std::ldexp(v.y(), log2), std::ldexp(v.z(), log2)); },
      [log2](Shape& s) { s = rayproof::scaled(s, std::ldexp(1.0, log2)); }, "scaled");
}

Scene translated(const Scene& scene, const Vec3& by) {
  return moved(
      scene, [&by](const Vec3& v) { return Vec3(v + by); },
      [&by](Shape& shape) {
        std::visit(
            [&](auto& s) {
              using S = std::decay_t<decltype(s)>;
              if constexpr (std::is_same_v<S, Sphere>)
                s.center += by;
              else if constexpr (std::is_same_v<S, Plane>)
                s.offset = s.offset + dot(s.normal, by);
              else if constexpr (std::is_same_v<S, Triangle>)
                for (Vec3& v : s.v) v += by;
              else {
                s.min += by;
                s.max += by;
              }
            },
            shape);
      },
      "translated");
}

}  // namespace rayproof
