// How much of sim://room-crowd's people its cameras can see at all (docs/detection.md, "The
// crowd"): for each person at each of the first 600 maps, in how many cameras at least 30 % of a
// 0.4 m x 1.65 m board across the line of sight (their silhouette) is in the image and not hidden
// by another person, chair or the robot. A detector that needs two views cannot find the people
// that fewer than two cameras see: this bounds its recall on the scene.
//   build/bench/crowd_visibility
#include <cstdio>
#include <memory>
#include <vector>

#include "capture/sim/scene.h"
#include "core/camera.h"
#include "core/tsai_camera.h"

using namespace occmap;
int main() {
  auto scene = sim::makeScene("room-crowd");
  std::vector<Eigen::Vector3d> eyes;
  std::vector<Camera> cams;
  for (const auto& c : scene->cameras()) {
    Camera cam(std::make_shared<TsaiCamera>(c.calibration), LengthUnit::kMillimetre, 640, 480);
    eyes.push_back(cam.centreMetres());
    cams.push_back(cam);
  }
  long person_maps = 0, two = 0, one = 0, none = 0;
  long hist[5] = {0, 0, 0, 0, 0};
  for (int f = 0; f < 600; ++f) {
    const auto objects = scene->objectsAt(static_cast<double>(f) / 30.0);
    for (std::size_t i = 0; i < objects.size(); ++i) {
      if (objects[i].kind != sim::ObjectKind::kPerson) continue;
      ++person_maps;
      int seeing = 0;
      for (std::size_t k = 0; k < eyes.size(); ++k) {
        const auto& eye = eyes[k];
        int visible = 0, samples = 0;
        for (double z = 0.1; z < 1.75; z += 0.15) {  // 11 heights x 5 across
          for (double side = -0.2; side <= 0.2; side += 0.1) {
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
      ++hist[std::min(seeing, 4)];
      if (seeing >= 2)
        ++two;
      else if (seeing == 1)
        ++one;
      else
        ++none;
    }
  }
  const auto share = [&](long n) {
    return 100.0 * static_cast<double>(n) / static_cast<double>(person_maps);
  };
  std::printf(
      "sim://room-crowd, 600 maps, %ld person-maps: at least 30 %% of the silhouette seen by two "
      "cameras or more %.1f %%, by one %.1f %%, by none %.1f %%\n",
      person_maps, share(two), share(one), share(none));
  for (int k = 0; k < 5; ++k) std::printf("  by %d cameras: %.1f %%\n", k, share(hist[k]));
}
