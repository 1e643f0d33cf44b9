// How much of sim://room-crowd's people and objects its cameras can see at all (docs/detection.md,
// "The crowd"): for each object at each of the first 600 maps, in how many cameras at least 30 %
// of a board across the line of sight (its silhouette: a person's 0.4 m x 1.65 m, a chair's or the
// robot's as wide and high as it) is in the image and not hidden by another object. A detector
// that needs two views cannot find what fewer than two cameras see: this bounds its recall on the
// scene, kind by kind (the 0.35 m robot, in its corner, is seen by two on 68.7 % of its maps).
// Another crowd by its name (sim://room-crowd-N):
//   build/bench/crowd_visibility [room-crowd-3]
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "capture/sim/scene.h"
#include "core/camera.h"
#include "core/tsai_camera.h"

using namespace occmap;
int main(int argc, char** argv) {
  const std::string name = argc > 1 ? argv[1] : "room-crowd";
  auto scene = sim::makeScene(name);
  if (!scene || name.rfind("room-crowd", 0) != 0) {
    std::fprintf(stderr, "crowd_visibility: '%s' is not a crowd; give room-crowd or room-crowd-N\n",
                 name.c_str());
    return 2;
  }
  std::vector<Eigen::Vector3d> eyes;
  std::vector<Camera> cams;
  for (const auto& c : scene->cameras()) {
    Camera cam(std::make_shared<TsaiCamera>(c.calibration), LengthUnit::kMillimetre, 640, 480);
    eyes.push_back(cam.centreMetres());
    cams.push_back(cam);
  }
  // Per kind (person, chair, robot, box): the object-maps seen by 0, 1, 2, 3 and 4 cameras.
  long seen_by[4][5] = {};
  for (int f = 0; f < 600; ++f) {
    const auto objects = scene->objectsAt(static_cast<double>(f) / 30.0);
    for (std::size_t i = 0; i < objects.size(); ++i) {
      const bool person = objects[i].kind == sim::ObjectKind::kPerson;
      const sim::Solid& solid = objects[i].solid;
      // Its silhouette: a person's as above, and what stands lower as its own size.
      const double half = person ? 0.2 : solid.half_size.x() * 0.9;
      const double top = person ? 1.75 : solid.height;
      int seeing = 0;
      for (std::size_t k = 0; k < eyes.size(); ++k) {
        const auto& eye = eyes[k];
        int visible = 0, samples = 0;
        for (double z = top / 17.5; z < top; z += top * 0.15 / 1.75) {  // 11 heights x 5 across
          for (double side = -half; side <= half * 1.0001; side += half / 2) {
            // A point on the person's silhouette across the line of sight.
            Eigen::Vector2d c = objects[i].solid.centre;
            Eigen::Vector2d to(eye.x() - c.x(), eye.y() - c.y());
            Eigen::Vector2d across(-to.y(), to.x());
            across.normalize();
            Eigen::Vector3d p(c.x() + side * across.x(), c.y() + side * across.y(), z);
            Eigen::Vector3d d = eye - p;
            ++samples;
            const auto px = cams[k].worldToStream(p);
            bool blocked = !px || px->x() < 0 || px->y() < 0 || px->x() > 639 || px->y() > 479;
            for (std::size_t j = 0; j < objects.size() && !blocked; ++j) {
              if (j == i) continue;
              if (objects[j].solid.intersect(p, d, 1e-6, 1.0)) blocked = true;
            }
            visible += blocked ? 0 : 1;
          }
        }
        if (visible >= samples * 3 / 10) ++seeing;
      }
      ++seen_by[static_cast<int>(objects[i].kind)][std::min(seeing, 4)];
    }
  }
  const char* const kinds[4] = {"person", "chair", "robot", "box"};
  for (int kind = 0; kind < 4; ++kind) {
    const long* h = seen_by[kind];
    const long maps = h[0] + h[1] + h[2] + h[3] + h[4];
    if (maps == 0) continue;
    const auto share = [&](long n) {
      return 100.0 * static_cast<double>(n) / static_cast<double>(maps);
    };
    std::printf(
        "sim://%s, 600 maps, %ld %s-maps: at least 30 %% of the silhouette seen by two "
        "cameras or more %.1f %%, by one %.1f %%, by none %.1f %%\n",
        name.c_str(), maps, kinds[kind], share(h[2] + h[3] + h[4]), share(h[1]), share(h[0]));
    for (int k = 0; k < 5; ++k) std::printf("  by %d cameras: %.1f %%\n", k, share(h[k]));
  }
}
