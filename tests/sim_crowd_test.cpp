// The simulator's crowds (issue 14): "room-crowd" and its numbered kin "room-crowd-N", each twelve
// people walking among the room's chairs and robot, never through each other. The tracker is
// scored over several of them, so each must be a crowd of its own and keep the scene's rules.
#include <algorithm>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "capture/sim/scene.h"

namespace occmap {
namespace {

std::vector<Eigen::Vector2d> peopleAmong(const std::vector<sim::SceneObject>& objects) {
  std::vector<Eigen::Vector2d> people;
  for (const sim::SceneObject& object : objects) {
    if (object.kind == sim::ObjectKind::kPerson) people.push_back(object.solid.centre);
  }
  return people;
}

// Each crowd keeps its people a body's width and the clearance apart (2 x 0.25 + 0.1 m), and off
// the chairs and the robot, at every 50 ms of its 20 s; and is named as it was asked for.
TEST(SimCrowd, EveryCrowdKeepsItsPeopleApartAndOffTheFurniture) {
  for (const std::string name : {"room-crowd", "room-crowd-1", "room-crowd-2", "room-crowd-17"}) {
    SCOPED_TRACE(name);
    const std::unique_ptr<sim::Scene> scene = sim::makeScene(name);
    ASSERT_NE(scene, nullptr);
    EXPECT_EQ(scene->name(), name);
    double closest_people = 1e9, closest_furniture = 1e9;
    for (int k = 0; k * 0.05 < scene->durationS(); ++k) {
      const std::vector<sim::SceneObject> objects = scene->objectsAt(k * 0.05);
      const std::vector<Eigen::Vector2d> people = peopleAmong(objects);
      ASSERT_EQ(people.size(), 12u);
      for (std::size_t i = 0; i < people.size(); ++i) {
        for (std::size_t j = i + 1; j < people.size(); ++j) {
          closest_people = std::min(closest_people, (people[i] - people[j]).norm());
        }
        for (const sim::SceneObject& object : objects) {
          if (object.kind == sim::ObjectKind::kPerson) continue;
          closest_furniture =
              std::min(closest_furniture, object.solid.footprintDistance(people[i]));
        }
      }
    }
    // The scene checks at its own 50 ms steps; between them a walker moves at most 6.5 cm.
    EXPECT_GE(closest_people, 0.6 - 1e-9);
    EXPECT_GE(closest_furniture, 0.35 - 1e-9);
  }
}

// Each seed is another crowd: no two of the four place any person alike at the start, and the
// same name gives the same crowd every time.
TEST(SimCrowd, EachSeedIsAnotherCrowdAndTheSameSeedTheSameOne) {
  std::vector<std::vector<Eigen::Vector2d>> starts;
  for (const std::string name : {"room-crowd", "room-crowd-1", "room-crowd-2", "room-crowd-3"}) {
    const std::unique_ptr<sim::Scene> scene = sim::makeScene(name), again = sim::makeScene(name);
    starts.push_back(peopleAmong(scene->objectsAt(0.0)));
    EXPECT_EQ(peopleAmong(scene->objectsAt(7.3)), peopleAmong(again->objectsAt(7.3))) << name;
  }
  for (std::size_t a = 0; a < starts.size(); ++a) {
    for (std::size_t b = a + 1; b < starts.size(); ++b) {
      for (const Eigen::Vector2d& person : starts[a]) {
        for (const Eigen::Vector2d& other : starts[b]) {
          EXPECT_GT((person - other).norm(), 1e-6) << "crowds " << a << " and " << b;
        }
      }
    }
  }
}

// A crowd's number is written as people write numbers: "room-crowd-0" would be room-crowd under a
// second name and "room-crowd-01" room-crowd-1, so neither is a scene; nor is anything but digits.
TEST(SimCrowd, OnlyAPlainNumberNamesACrowd) {
  for (const char* name : {"room-crowd-0", "room-crowd-01", "room-crowd-", "room-crowd-x",
                           "room-crowd-1x", "room-crowd--1", "room-crowd-99999999999"}) {
    EXPECT_EQ(sim::makeScene(name), nullptr) << name;
  }
}

}  // namespace
}  // namespace occmap
