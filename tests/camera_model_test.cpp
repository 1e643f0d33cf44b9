// Camera geometry on analytic cases: what a user relies on when a calibration says where a pixel
// looks.
#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "core/camera.h"
#include "core/opencv_camera.h"
#include "core/tsai_camera.h"

namespace occmap {
namespace {

// A 640x480 camera 3000 mm above the world origin looking straight down: rx = pi turns the camera's
// +z (viewing direction) to world -z. With f = 6 mm and 0.01 mm pixels, 1 mm on the floor is
// f / (h dp) = 0.2 pixels.
TsaiParameters straightDown(double kappa1 = 0.0) {
  TsaiParameters p;
  p.width = 640;
  p.height = 480;
  p.ncx = p.nfx = 640;
  p.dx = p.dy = p.dpx = p.dpy = 0.01;
  p.focal = 6.0;
  p.kappa1 = kappa1;
  p.cx = 320;
  p.cy = 240;
  p.sx = 1.0;
  p.rx = std::numbers::pi;
  p.tz = 3000;  // camera centre = -R^T T = (0, 0, 3000)
  return p;
}

TEST(TsaiCamera, StraightDownProjectsTheFloorByFocalOverHeight) {
  const TsaiCamera camera(straightDown());
  EXPECT_NEAR(camera.pose().centre().z(), 3000.0, 1e-9);
  const auto origin = camera.worldToImage({0, 0, 0});
  ASSERT_TRUE(origin);
  EXPECT_NEAR(origin->pixel.x(), 320.0, 1e-9);
  EXPECT_NEAR(origin->pixel.y(), 240.0, 1e-9);
  EXPECT_NEAR(origin->depth, 3000.0, 1e-9);
  // Rx(pi) maps world +x to camera +x and world +y to camera -y.
  const auto point = camera.worldToImage({500, 250, 0});
  ASSERT_TRUE(point);
  EXPECT_NEAR(point->pixel.x(), 320.0 + 500 * 0.2, 1e-9);
  EXPECT_NEAR(point->pixel.y(), 240.0 - 250 * 0.2, 1e-9);
  // A point 1000 mm above the floor is nearer: 6 / (2000 * 0.01) = 0.3 pixels per mm.
  const auto raised = camera.worldToImage({500, 0, 1000});
  ASSERT_TRUE(raised);
  EXPECT_NEAR(raised->pixel.x(), 320.0 + 500 * 0.3, 1e-9);
  EXPECT_NEAR(raised->depth, 2000.0, 1e-9);
}

TEST(TsaiCamera, PixelToFloorInvertsProjectionAtAnyHeight) {
  const TsaiCamera camera(straightDown(2e-3));
  for (double z : {0.0, 500.0, 1750.0}) {
    for (double x = -2000; x <= 2000; x += 400) {
      for (double y = -1500; y <= 1500; y += 500) {
        const auto image = camera.worldToImage({x, y, z});
        ASSERT_TRUE(image) << x << " " << y << " " << z;
        const auto back = camera.imageToPlane(image->pixel, z);
        ASSERT_TRUE(back);
        EXPECT_NEAR(back->world.x(), x, 1e-7);
        EXPECT_NEAR(back->world.y(), y, 1e-7);
        EXPECT_EQ(back->world.z(), z);
        EXPECT_NEAR(back->depth, image->depth, 1e-7);
      }
    }
  }
}

TEST(TsaiCamera, BehindTheCameraHasNoImage) {
  const TsaiCamera camera(straightDown());
  EXPECT_FALSE(camera.worldToImage({0, 0, 3000}));  // in the focal plane
  EXPECT_FALSE(camera.worldToImage({0, 0, 4000}));  // above a downward camera
  EXPECT_FALSE(camera.worldToImage({100, 50, 3000.0000001}));
  EXPECT_TRUE(camera.worldToImage({0, 0, 2999.999}));
}

TEST(TsaiCamera, PlaneBehindTheCameraIsNoResult) {
  const TsaiCamera camera(straightDown());
  // The camera is at 3000 mm looking down: the plane z = 3500 lies behind it for every pixel.
  EXPECT_FALSE(camera.imageToPlane({320, 240}, 3500));
  EXPECT_FALSE(camera.imageToPlane({10, 10}, 3000));
  EXPECT_TRUE(camera.imageToPlane({10, 10}, 2999));
}

TEST(TsaiCamera, HorizontalCameraSeesNoFloorAboveTheHorizon) {
  // Looking along world +y from 1000 mm up: rx = pi/2 sends camera +z (the view) to world +y and
  // camera +y (image down) to world -z.
  TsaiParameters p = straightDown();
  p.rx = std::numbers::pi / 2;
  p.tz = 0;
  p.ty = 1000;  // centre = -R^T T: (0, 0, 1000)
  const TsaiCamera camera(p);
  ASSERT_NEAR(camera.pose().centre().z(), 1000.0, 1e-9);
  EXPECT_TRUE(camera.imageToPlane({320, 400}, 0.0));     // below the horizon: the floor
  EXPECT_FALSE(camera.imageToPlane({320, 240}, 0.0));    // on the horizon: parallel to the floor
  EXPECT_FALSE(camera.imageToPlane({320, 100}, 0.0));    // above it: the ray rises
  EXPECT_TRUE(camera.imageToPlane({320, 100}, 1500.0));  // but meets a plane above the camera
}

TEST(TsaiCamera, NegativeKappaHasABarrelLimit) {
  // kappa1 < 0: Ru = Rd (1 + k Rd^2) peaks at Rd* = sqrt(-1 / 3k) with Ru* = 2/3 Rd*.
  const double kappa1 = -0.06;
  const TsaiCamera camera(straightDown(kappa1));
  const double rd_max = std::sqrt(-1.0 / (3.0 * kappa1));
  EXPECT_NEAR(camera.maxDistortedRadius(), rd_max, 1e-12);
  EXPECT_NEAR(camera.maxUndistortedRadius(), 2.0 / 3.0 * rd_max, 1e-12);
  // Inside the limit, the smaller positive root of the cubic: it satisfies the model and lies below
  // Rd*.
  for (double fraction : {0.01, 0.3, 0.7, 0.99, 0.999999}) {
    const double ru = fraction * camera.maxUndistortedRadius();
    const auto rd = camera.distortedRadius(ru);
    ASSERT_TRUE(rd) << fraction;
    EXPECT_NEAR(*rd * (1 + kappa1 * *rd * *rd), ru, 1e-12) << fraction;
    EXPECT_LE(*rd, rd_max * (1 + 1e-9)) << fraction;
  }
  EXPECT_FALSE(camera.distortedRadius(camera.maxUndistortedRadius() * 1.001));
  // A world point past the limit has no image; one just inside has one, inside the distorted limit.
  const double f = 6.0;
  const double height = 3000.0;
  const double x_limit = camera.maxUndistortedRadius() / f * height;
  EXPECT_TRUE(camera.worldToImage({x_limit * 0.999, 0, 0}));
  EXPECT_FALSE(camera.worldToImage({x_limit * 1.001, 0, 0}));
  // A pixel past the distorted limit would fold back: no ray.
  const double pixels_to_limit = rd_max / 0.01;
  EXPECT_TRUE(camera.imageToRay({320 + 0.999 * pixels_to_limit, 240}));
  EXPECT_FALSE(camera.imageToRay({320 + 1.001 * pixels_to_limit, 240}));
}

TEST(TsaiCamera, PositiveKappaDistortsInwardsAndAlwaysHasAnImage) {
  const TsaiCamera camera(straightDown(5e-3));
  for (double ru : {0.1, 1.0, 10.0, 1000.0}) {
    const auto rd = camera.distortedRadius(ru);
    ASSERT_TRUE(rd);
    EXPECT_LT(*rd, ru);
    EXPECT_NEAR(*rd * (1 + 5e-3 * *rd * *rd), ru, 1e-9 * ru);
  }
}

TEST(Camera, StreamCoversARegionScaledPerAxis) {
  // EPFL Terrace: calibration 720x576, images 360x288.
  TsaiParameters p = straightDown();
  p.width = 720;
  p.height = 576;
  auto model = std::make_shared<TsaiCamera>(p);
  const Camera half(model, LengthUnit::kMillimetre, 360, 288);
  // Calibration pixel centres 0 and 1 cover stream pixel 0 (centre at 0.5 calibration pixels).
  EXPECT_NEAR(half.calibrationToStream({0.5, 0.5}).x(), 0.0, 1e-12);
  EXPECT_NEAR(half.calibrationToStream({718.5, 574.5}).y(), 287.0, 1e-12);
  EXPECT_NEAR(half.calibrationToStream({-0.5, -0.5}).x(), -0.5, 1e-12);  // outer edges agree
  EXPECT_NEAR(half.calibrationToStream({718.5, 574.5}).x(), 359.0, 1e-12);
  // A crop with 2x binning in x only: region [100, 50, 400, 300] into a 200x300 stream.
  const Camera crop(model, LengthUnit::kMillimetre, 200, 300, ImageRegion{100, 50, 400, 300});
  EXPECT_NEAR(crop.calibrationToStream({100.5, 50}).x(), 0.0, 1e-12);
  EXPECT_NEAR(crop.calibrationToStream({100.5, 50}).y(), 0.0, 1e-12);
  for (const Eigen::Vector2d& s : {Eigen::Vector2d(3.25, 7.5), Eigen::Vector2d(-2, 400)}) {
    EXPECT_NEAR((crop.calibrationToStream(crop.streamToCalibration(s)) - s).norm(), 0, 1e-12);
  }
  // World points in metres land on the same spot either way.
  const Camera full(model, LengthUnit::kMillimetre, 720, 576);
  const auto a = full.worldToStream({0.4, -0.3, 0});
  const auto b = half.worldToStream({0.4, -0.3, 0});
  ASSERT_TRUE(a && b);
  EXPECT_NEAR((b->array() + 0.5).x(), (a->array() + 0.5).x() / 2, 1e-9);
  EXPECT_NEAR((b->array() + 0.5).y(), (a->array() + 0.5).y() / 2, 1e-9);
  const auto floor = half.streamToPlane(*b, 0.0);
  ASSERT_TRUE(floor);
  EXPECT_NEAR(floor->x(), 0.4, 1e-9);
  EXPECT_NEAR(floor->y(), -0.3, 1e-9);
  EXPECT_EQ(half.pixelIndexAt({359.49, 287.49}), 287 * 360 + 359);
  EXPECT_FALSE(half.pixelIndexAt({359.5, 0}));
  EXPECT_FALSE(half.pixelIndexAt({-0.51, 0}));
  EXPECT_EQ(half.pixelIndexAt({-0.5, -0.5}), 0);
}

TEST(OpenCvCamera, StopsWhereTheRadialPolynomialStopsIncreasing) {
  OpenCvParameters p;
  p.width = 640;
  p.height = 480;
  p.fx = p.fy = 500;
  p.cx = 320;
  p.cy = 240;
  p.distortion = {-0.3, 0.0, 0.0, 0.0, 0.0};  // r (1 - 0.3 r^2): slope 1 - 0.9 r^2 = 0 at r = 1.054
  const OpenCvCamera camera(p);
  EXPECT_NEAR(camera.maxRadius(), std::sqrt(1 / 0.9), 1e-12);
  p.distortion = {0.1, 0.01, 0.0, 0.0, 0.0};  // always increasing
  EXPECT_TRUE(std::isinf(OpenCvCamera(p).maxRadius()));
}

}  // namespace
}  // namespace occmap

namespace occmap {
namespace {

// An independent transcription of Willson's cal_tran.c (world_coord_to_image_coord with its r1..r9
// and undistorted_to_distorted_sensor_coord), to hold TsaiCamera to the reference, not to itself.
std::optional<Eigen::Vector2d> willsonWorldToImage(const TsaiParameters& cp, double xw, double yw,
                                                   double zw) {
  const double sa = std::sin(cp.rx), ca = std::cos(cp.rx);
  const double sb = std::sin(cp.ry), cb = std::cos(cp.ry);
  const double sg = std::sin(cp.rz), cg = std::cos(cp.rz);
  const double r1 = cb * cg, r2 = cg * sa * sb - ca * sg, r3 = sa * sg + ca * cg * sb;
  const double r4 = cb * sg, r5 = sa * sb * sg + ca * cg, r6 = ca * sb * sg - cg * sa;
  const double r7 = -sb, r8 = cb * sa, r9 = ca * cb;
  const double xc = r1 * xw + r2 * yw + r3 * zw + cp.tx;
  const double yc = r4 * xw + r5 * yw + r6 * zw + cp.ty;
  const double zc = r7 * xw + r8 * yw + r9 * zw + cp.tz;
  if (zc <= 0) return std::nullopt;
  const double Xu = cp.focal * xc / zc;
  const double Yu = cp.focal * yc / zc;
  double Xd = Xu, Yd = Yu;
  if (!((Xu == 0 && Yu == 0) || cp.kappa1 == 0)) {
    const double Ru = std::hypot(Xu, Yu);
    const double c = 1 / cp.kappa1;
    const double d = -c * Ru;
    const double Q = c / 3;
    const double R = -d / 2;
    double D = Q * Q * Q + R * R;
    double Rd;
    if (D >= 0) {
      D = std::sqrt(D);
      Rd = std::cbrt(R + D) + std::cbrt(R - D);
      if (Rd < 0) return std::nullopt;  // Willson clamps to the barrel limit here and warns
    } else {
      D = std::sqrt(-D);
      const double S = std::cbrt(std::hypot(R, D));
      const double T = std::atan2(D, R) / 3;
      Rd = -S * std::cos(T) + std::sqrt(3.0) * S * std::sin(T);
    }
    const double lambda = Rd / Ru;
    Xd = Xu * lambda;
    Yd = Yu * lambda;
  }
  return Eigen::Vector2d(Xd * cp.sx / cp.dpx + cp.cx, Yd / cp.dpy + cp.cy);
}

TEST(TsaiCamera, AgreesWithWillsonsReferenceCode) {
  std::mt19937_64 rng(1999);
  std::uniform_real_distribution<double> unit(-1, 1);
  int compared = 0;
  for (int trial = 0; trial < 200; ++trial) {
    TsaiParameters p = straightDown(trial % 2 ? 4e-3 * (unit(rng) + 1) : -0.05 * (unit(rng) + 1.1));
    p.rx = 2.0 + 0.6 * unit(rng);  // PETS-like poses: tilted, rolled, far from the origin
    p.ry = 0.9 * unit(rng);
    p.rz = 0.5 * unit(rng);
    p.tx = 3000 * unit(rng);
    p.ty = 3000 * unit(rng);
    p.tz = 8000 + 5000 * unit(rng);
    p.sx = 1.0 + 0.1 * unit(rng);
    p.dpx = 0.01 * p.sx;
    const TsaiCamera camera(p);
    for (int k = 0; k < 50; ++k) {
      const Eigen::Vector3d world(20000 * unit(rng), 20000 * unit(rng), 2000 * (unit(rng) + 1));
      const auto ours = camera.worldToImage(world);
      const auto reference = willsonWorldToImage(p, world.x(), world.y(), world.z());
      ASSERT_EQ(ours.has_value(), reference.has_value()) << "trial " << trial;
      if (!ours) continue;
      ASSERT_NEAR((ours->pixel - *reference).norm(), 0.0, 1e-9 * (1 + reference->norm()))
          << "trial " << trial;
      ++compared;
    }
  }
  EXPECT_GT(compared, 2000);
}

}  // namespace
}  // namespace occmap
