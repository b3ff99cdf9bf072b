// The renderer checked by properties of the seed scenes, scale invariance of shadows, and the
// command line's answers to bad input.
#include <gtest/gtest.h>
#include <unistd.h>

#include "test_dir.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <sstream>
#include <sys/wait.h>

#include "rayproof/core/json_fields.h"
#include "rayproof/core/render.h"

namespace rayproof {
namespace {

const std::string kScenes = RAYPROOF_SCENES_DIR;

bool is_background(const Image& img, int x, int y) {
  const auto p = img.at(x, y);
  return p[0] == 0 && p[1] == 0 && p[2] == 0;
}

TEST(Seed1, DiskHasTheAnalyticSilhouetteArea) {
  const Scene scene = load_scene(kScenes + "/seed1-sphere.json");
  const Image img = render(scene);
  long count = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) count += !is_background(img, x, y);
  // The silhouette is a cone of half-angle asin(r / distance) around the view axis, a disk of
  // radius tan(α) on the image plane at distance 1, i.e. tan(α)·H / (2·tan(fov/2)) pixels.
  const Sphere& s = std::get<Sphere>(scene.objects[0].shape);
  const double distance = length(s.center - scene.camera.eye);
  const double alpha = std::asin(s.radius / distance);
  const double pixels_per_unit = img.height / (scene.camera.window_top - scene.camera.window_bottom);
  const double radius_px = std::tan(alpha) * pixels_per_unit;
  const double analytic = std::numbers::pi * radius_px * radius_px;
  EXPECT_NEAR(count, analytic, 0.01 * analytic);
  // Flat shading: every sphere pixel has exactly the sphere's colour (1, 0, 0) → (255, 0, 0).
  const auto centre = img.at(img.width / 2, img.height / 2);
  EXPECT_EQ(centre[0], 255);
  EXPECT_EQ(centre[1], 0);
}

TEST(Seed2, OnlyTheUpperHalfIsLitAndTheBrightestPixelIsNearTheTop) {
  const Scene scene = load_scene(kScenes + "/seed2-diffuse.json");
  const SceneIndex index(scene);
  const Image img = render(scene);
  const double centre_row = img.height / 2.0;  // the sphere's centre lies on the view axis
  long lit = 0, unlit_sphere_pixels = 0;
  int best = -1, best_row = -1;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const int red = img.at(x, y)[0];
      if (red > 0) {
        ++lit;
        EXPECT_LT(y + 0.5, centre_row) << "lit pixel below the centre row at " << x << "," << y;
        if (red > best) best = red, best_row = y;
      }
      // A pixel whose ray hits the sphere but is dark: the lower half.
      const SceneHit h = trace(index, Intersectors::defaults(), scene.camera.ray_through(x + 0.5, y + 0.5));
      if (h.object >= 0 && red == 0) ++unlit_sphere_pixels;
    }
  EXPECT_GT(lit, 1000);
  EXPECT_GT(unlit_sphere_pixels, 1000);
  const double radius_px = std::tan(std::asin(0.5)) * img.height / 2.0;
  EXPECT_LT(best_row, centre_row - radius_px / 2);
}

// Independent geometry for the tests below: the nearest hit of a ray among spheres and planes,
// solved in long double with the textbook formula (no library intersector involved).
struct Analytic {
  long double t = -1;  // < 0: no hit
  int object = -1;
  long double discriminant_margin = 0;  // D / b² of the sphere hit: small near a silhouette
};
Analytic nearest_hit(const Scene& scene, const Ray& r) {
  Analytic best;
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    const Shape& shape = scene.objects[i].shape;
    long double t = -1, margin = 1;
    if (const auto* s = std::get_if<Sphere>(&shape)) {
      long double f[3], d[3];
      for (int k = 0; k < 3; ++k) f[k] = (long double)r.origin[k] - s->center[k], d[k] = r.direction[k];
      const long double a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
      const long double b = f[0] * d[0] + f[1] * d[1] + f[2] * d[2];
      const long double c = f[0] * f[0] + f[1] * f[1] + f[2] * f[2] - (long double)s->radius * s->radius;
      const long double disc = b * b - a * c;
      if (disc < 0) continue;
      t = (-b - std::sqrt(disc)) / a;
      margin = disc / (b * b);
    } else if (const auto* p = std::get_if<Plane>(&shape)) {
      long double nd = 0, no = 0;
      for (int k = 0; k < 3; ++k)
        nd += (long double)p->normal[k] * r.direction[k], no += (long double)p->normal[k] * r.origin[k];
      if (nd == 0) continue;
      t = (p->offset - no) / nd;
    }
    if (t > 0 && (best.t < 0 || t < best.t)) best = {t, int(i), margin};
  }
  return best;
}

TEST(Shadows, TheImageIsTheSameAtEveryPowerOfTwoScale) {
  // Exact power-of-two scaling maps every ray to the scaled ray, so a renderer free of
  // scale-dependent epsilons draws the same image at every scale.
  const Scene base = load_scene(kScenes + "/all-shapes.json");
  const Image reference = render(base);
  long lit = 0;
  for (auto v : reference.rgb) lit += v > 0;
  EXPECT_GT(lit, 10000);
  for (int k : {-40, -20, 20, 40}) {
    const Image img = render(scaled(base, k));
    long differing = 0;
    for (size_t i = 0; i < img.rgb.size(); ++i) differing += img.rgb[i] != reference.rgb[i];
    EXPECT_EQ(differing, 0) << "scale 2^" << k;
  }
}

TEST(Shadows, LitSideOfASphereIsLitAndItsDarkSideDarkAtEveryScale) {
  // A sphere alone under a light, judged against geometry solved in long double: every pixel
  // whose surface clearly faces the light must be lit in the rendered image (acne would darken
  // it), every pixel clearly facing away must be black.
  for (int k : {-30, 0, 30}) {
    const Scene scene = scaled(load_scene(kScenes + "/seed2-diffuse.json"), k);
    ASSERT_EQ(scene.objects.size(), 1u);
    const Sphere& sphere = std::get<Sphere>(scene.objects[0].shape);
    const Image img = render(scene);
    const int grid = static_cast<int>(std::lround(std::sqrt(scene.samples)));
    long lit_side = 0, dark_side = 0, acne = 0, leaks = 0;
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) {
        // Judge by the worst sub-pixel sample: all must agree for the pixel to count.
        long double lo = 2, hi = -2;
        bool all_hit = true;
        for (int sy = 0; sy < grid; ++sy)
          for (int sx = 0; sx < grid; ++sx) {
            const Ray r = scene.camera.ray_through(x + (sx + 0.5) / grid, y + (sy + 0.5) / grid);
            const Analytic h = nearest_hit(scene, r);
            if (h.t <= 0 || h.discriminant_margin < 1e-3L) {
              all_hit = false;
              continue;
            }
            long double p[3], n[3], l[3], nn = 0, ll = 0, dot_nl = 0;
            for (int a = 0; a < 3; ++a) {
              p[a] = r.origin[a] + h.t * r.direction[a];
              n[a] = p[a] - sphere.center[a];
              l[a] = scene.lights[0].position[a] - p[a];
              nn += n[a] * n[a], ll += l[a] * l[a], dot_nl += n[a] * l[a];
            }
            const long double facing = dot_nl / std::sqrt(nn * ll);
            lo = std::min(lo, facing), hi = std::max(hi, facing);
          }
        if (!all_hit) continue;
        const int value = img.at(x, y)[0] + img.at(x, y)[1] + img.at(x, y)[2];
        if (lo > 0.05L) ++lit_side, acne += value == 0;
        if (hi < -0.05L) ++dark_side, leaks += value != 0;
      }
    EXPECT_GT(lit_side, 1000) << "scale 2^" << k;
    EXPECT_GT(dark_side, 1000) << "scale 2^" << k;
    EXPECT_EQ(acne, 0) << "scale 2^" << k;
    EXPECT_EQ(leaks, 0) << "scale 2^" << k;
  }
}

TEST(Render, ImagesRoundTripThroughPngAndThreadsAgree) {
  const Scene scene = load_scene(kScenes + "/depth.json");
  RenderOptions one, many;
  one.threads = 1;
  many.threads = 4;
  const Image a = render(scene, one), b = render(scene, many);
  EXPECT_EQ(a.rgb, b.rgb);
  const std::string path = rayproof::testing_support::test_dir() + "/depth.png";
  write_image(a, path);
  const Image back = read_png(path);
  EXPECT_EQ(back.width, a.width);
  EXPECT_EQ(back.rgb, a.rgb);
}

// Every pixel of the depth scene has the grey level its analytic distance predicts (one sample
// per pixel), so nearer surfaces are brighter; only pixels on a silhouette may differ.
TEST(Render, DepthShadingFollowsTheAnalyticDistance) {
  const Scene scene = load_scene(kScenes + "/depth.json");
  ASSERT_EQ(scene.samples, 1);
  const Image img = render(scene);
  long checked = 0, off = 0, nearer_darker = 0;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const Ray r = scene.camera.ray_through(x + 0.5, y + 0.5);
      const Analytic h = nearest_hit(scene, r);
      long double grey = 0;
      if (h.t > 0) {
        long double dist2 = 0;
        for (int k = 0; k < 3; ++k) dist2 += (h.t * r.direction[k]) * (h.t * r.direction[k]);
        grey = (scene.depth_far - std::sqrt(dist2)) / (scene.depth_far - scene.depth_near);
        grey = std::clamp(grey, 0.0L, 1.0L);
      }
      const int want = static_cast<int>(std::lround(grey * 255)), got = img.at(x, y)[0];
      ++checked;
      off += std::abs(want - got) > 1;
      // Ordering: along a row, a pixel whose surface is nearer by a clear margin is brighter.
      if (x > 0 && h.t > 0) {
        const Analytic left = nearest_hit(scene, scene.camera.ray_through(x - 0.5, y + 0.5));
        if (left.t > 0 && left.t > h.t * 1.05L && img.at(x - 1, y)[0] > got) ++nearer_darker;
      }
    }
  EXPECT_GT(checked, 70000);
  EXPECT_LT(off, checked / 200);  // silhouettes only
  EXPECT_LT(nearer_darker, 10);
}

TEST(Render, WindowCameraFollowsTheSpecFormula) {
  // Window camera at the origin looking down +z: pixel (i, j) leaves along
  // f + sx·r + sy·u with sx = left + (i+½)/W·(right−left), sy = top + (j+½)/H·(bottom−top).
  const Scene scene = parse_scene(R"({"camera": {"eye": [0,0,0], "left": -2, "right": 2, "top": 1,
      "bottom": -1, "width": 4, "height": 2}, "objects": []})",
                                  "inline");
  const Ray r = scene.camera.ray_through(0.5, 0.5);
  // f = (0,0,1), up default (0,1,0): r = normalize(f × up) = (−1,0,0), u = r × f = (0,1,0).
  EXPECT_DOUBLE_EQ(r.direction.z(), 1.0);
  EXPECT_DOUBLE_EQ(r.direction.x(), 1.5);  // sx = −1.5 along r = (−1,0,0)
  EXPECT_DOUBLE_EQ(r.direction.y(), 0.5);  // sy = 0.5 along u = (0,1,0)
}

struct CliResult {
  int status;
  std::string output;
};

CliResult run_cli(const std::string& args) {
  const std::string cmd = std::string(RAYPROOF_CLI) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

std::string write_temp(const std::string& name, const std::string& text) {
  const std::string path = rayproof::testing_support::test_dir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

TEST(Cli, BadScenesGiveAClearErrorAndNonZeroExit) {
  const std::string camera =
      R"("camera": {"eye": [-1,0,1], "look_at": [0,0,1], "up": [0,0,1], "fov_deg": 60, "width": 8, "height": 6})";
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"{" + camera + R"(, "objects": [{"type": "sphere", "center": [1,0,"nan"], "radius": 1}]})",
       "objects[0].center[2]"},
      {"{" + camera + R"(, "objects": [{"type": "sphere", "center": [1,0,1], "radius": -1}]})", "objects[0].radius"},
      {"{" + camera + R"(, "objects": [{"type": "sphere", "center": [1,0,1e999], "radius": 1}]})",
       "objects[0].center[2]"},
      {"{" + camera + R"(, "objects": [{"type": "triangle", "vertices": [[0,0,0],[1,1,1],[2,2,2]]}]})",
       "objects[0].vertices"},
      {"{" + camera + R"(, "objects": [{"type": "box", "min": [0,0,0], "max": [0,1,1]}]})", "objects[0].max"},
      {"{" + camera + R"(, "objects": [{"type": "sphere", "center": [1,0], "radius": 1}]})", "objects[0].center"},
      {"{" + camera + R"(, "objects": [], "shiny": true})", "shiny"},
      {"{" + camera + R"(, "objects": [], "shading": "depth"})", "depth"},
      {R"({"camera": {"eye": [0,0,0], "look_at": [0,0,0], "up": [0,0,1], "fov_deg": 60, "width": 8, "height": 6}, )"
       R"("objects": []})",
       "camera.look_at"},
      {"{" + camera + R"(, "objects": [)", "malformed JSON"},
      {"", "empty file"},
  };
  int i = 0;
  for (const auto& [text, needle] : bad) {
    const std::string path = write_temp("bad-scene-" + std::to_string(i++) + ".json", text);
    const CliResult r = run_cli("render " + path + " -o " + rayproof::testing_support::test_dir() + "/never.png");
    EXPECT_NE(r.status, 0) << text;
    EXPECT_NE(r.output.find(path), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(needle), std::string::npos) << needle << " not in: " << r.output;
  }
}

// Issue 26: coordinates at the ends of the double range. Centroids at ±1e308 made the BVH's bin
// index NaN → INT_MIN (SIGSEGV); a sphere whose bounds overflow to ∞ did too. Both scenes render,
// the near sphere is where it is, and audit's exact oracle judges them.
TEST(Hostile, ObjectsAtTheEndsOfTheDoubleRangeBuildABvhAndRender) {
  std::string objects = R"({"type": "sphere", "center": [0,0,0], "radius": 1, "color": [1,0,0]})";
  for (const char* x : {"1e308", "-1e308", "5e307", "-5e307", "1.7e308"})
    objects += std::string(R"(, {"type": "sphere", "center": [)") + x + R"(,0,0], "radius": 1})" +
               R"(, {"type": "box", "min": [)" + x + R"(,0,0], "max": [1.7976931348623157e308,1,1]})" +
               R"(, {"type": "triangle", "vertices": [[)" + x + R"(,0,0],[0,-1e308,0],[0,0,-1e308]]})";
  objects += R"(, {"type": "sphere", "center": [1e308,1e308,0], "radius": 1e308})";  // bounds overflow to ∞
  const std::string text = R"({"camera": {"eye": [0,0,-7], "look_at": [0,0,0], "up": [0,1,0], "fov_deg": 30,
      "width": 9, "height": 9}, "shading": "flat", "objects": [)" +
                           objects + "]}";
  const Scene scene = parse_scene(text, "extreme.json");
  const Image image = render(scene);
  const auto centre = image.at(4, 4);
  EXPECT_EQ(centre[0], 255);
  EXPECT_EQ(centre[1], 0) << "the centre pixel should see the red sphere at the origin";
  const std::string path = write_temp("extreme.json", text);
  const CliResult r =
      run_cli("audit " + path + " --variants stable -o " + rayproof::testing_support::test_dir() + "/extreme");
  EXPECT_EQ(r.status, 0) << r.output;
}

// Issue 26: a window whose rays would be infinite is refused (the oracle cannot hold ∞, and GMP
// raised SIGFPE); a look_at 1e154 away is a finite distance whose square overflows, and is kept.
TEST(Hostile, CameraRaysAreFiniteOrTheSceneIsRefused) {
  try {
    parse_scene(R"({"camera": {"eye": [0,0,-5], "left": -1e308, "right": 1e308, "top": 1, "bottom": -1,
        "width": 8, "height": 8}, "objects": []})",
                "window.json");
    ADD_FAILURE() << "a window of width 2e308 was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("camera.right"), std::string::npos) << e.what();
  }
  const Scene far = parse_scene(R"({"camera": {"eye": [0,0,0], "look_at": [0,0,1e154], "up": [0,1,0], "fov_deg": 60,
      "width": 8, "height": 8}, "objects": []})",
                                "far.json");
  EXPECT_EQ(far.camera.forward, Vec3(0, 0, 1));
  for (double x : {0.0, 8.0})
    for (double y : {0.0, 8.0}) {
      const Ray corner = far.camera.ray_through(x, y);
      EXPECT_TRUE(std::isfinite(corner.direction.x()) && std::isfinite(corner.direction.y()));
    }
}

TEST(Cli, IntersectReportsBadLinesAndKeepsTheGoodOnes) {
  const std::string path =
      write_temp("mixed-cases.jsonl", R"({"id": "ok", "ray": {"origin": [-3,0,0], "direction": [1,0,0]}, )"
                                      R"("shape": {"type": "sphere", "center": [0,0,0], "radius": 1}})"
                                      "\n"
                                      R"({"id": "bad", "ray": {"origin": [-3,0,0], "direction": [1,0,0]}, )"
                                      R"("shape": {"type": "sphere", "center": [0,0,0], "radius": "0x1p+1024"}})"
                                      "\n");
  const CliResult r = run_cli("intersect " + path + " --variants stable,textbook");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.output.find(R"("stable":{"class":"enter","t":"0x1p+1"})"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("mixed-cases.jsonl:2: field 'shape.radius'"), std::string::npos) << r.output;
  EXPECT_NE(run_cli("intersect " + path + " --variants no-such").status, 0);
  EXPECT_NE(run_cli("intersect " + write_temp("empty.jsonl", "")).status, 0);
  EXPECT_NE(run_cli("intersect /no/such/file.jsonl").status, 0);
}

}  // namespace
}  // namespace rayproof
