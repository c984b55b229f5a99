// A simulator with a scene (Simulator::set_scene): the step whose motion brings the collision
// shape to a wall is refused with status collided, at the step a closed form gives (the first
// step that reaches the wall's face grown by the shape's extent along x), naming the wall.

#include <gtest/gtest.h>

#include <memory>
#include <optional>
#include <string>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"
#include "dronetwin/sim/simulator.hpp"
#include "test_support.hpp"

namespace dronetwin {
namespace {

constexpr double kWallFace_m = 2.0;

std::shared_ptr<const Track> wall_scene() {
  auto scene = std::make_shared<Track>();
  Obstacle wall;
  wall.name = "wall";
  wall.shape = Obstacle::Shape::kBox;
  wall.center_m = Vec3(kWallFace_m + 0.5, 0.0, 1.5);
  wall.half_size_m = Vec3(0.5, 3.0, 3.0);
  scene->obstacles.push_back(wall);
  return scene;
}

// Drifting towards +x at 2 m/s at 1.5 m, rotors stopped and no gravity (no_gravity()): the
// frame drag slows it along a straight line without turning it.
void start(Simulator& sim) {
  StateVector x = Simulator::hover_state(Vec3(0.0, 0.0, 1.5));
  x[state_index::kVelocity] = 2.0;
  sim.reset(x);
}

SimConfig no_gravity() {
  SimConfig c;
  c.environment.gravity_W_m_s2.setZero();
  return c;
}

// How far the shape reaches along world +x from the body origin at this state.
double reach_x_m(const CollisionShape& shape, const StateVector& x) {
  const Mat3 R = math::rotation_matrix<double>(x.segment<4>(state_index::kQuaternion));
  const Vec3 c = R * shape.center_B_m;
  if (shape.kind == CollisionShape::Kind::kSphere) return c.x() + shape.radius_m;
  return c.x() + R.row(0).cwiseAbs().dot(shape.half_size_m);
}

void expect_collision_at_the_closed_form_step(std::shared_ptr<const VehicleModel> model) {
  const CollisionShape& shape = model->collision_shape();
  // The same flight without the scene: the first step at which the shape reaches the face.
  Simulator free(model, no_gravity());
  start(free);
  std::optional<std::int64_t> expected;
  StateVector before_contact;
  for (int k = 1; k <= 4000 && !expected; ++k) {
    const StateVector previous = free.state();
    ASSERT_TRUE(free.step().ok());
    if (free.state()[0] + reach_x_m(shape, free.state()) >= kWallFace_m) {
      expected = k;
      before_contact = previous;
    }
  }
  ASSERT_TRUE(expected.has_value());

  Simulator sim(model, no_gravity());
  sim.set_scene(wall_scene());
  start(sim);
  const StepResult r = sim.step(4000);
  EXPECT_EQ(r.status, StepStatus::kCollided);
  EXPECT_EQ(r.steps_taken, *expected - 1);
  EXPECT_EQ(sim.step_count(), *expected - 1);
  // The refused step committed nothing: the state is the last one before the contact.
  EXPECT_TRUE(sim.state() == before_contact);
  const std::string message = sim.failure_message();
  EXPECT_NE(message.find("collided with obstacle 'wall' (box)"), std::string::npos) << message;
  EXPECT_NE(message.find("during step " + std::to_string(*expected)), std::string::npos) << message;
  EXPECT_EQ(sim.data().failure.contact.kind, SceneContact::Kind::kObstacle);
  EXPECT_THROW(sim.step(), SimulationError);
  // The scene stays over a reset.
  start(sim);
  EXPECT_EQ(sim.step(4000).status, StepStatus::kCollided);
}

TEST(SimulatorScene, TheDefaultSphereHitsTheWallAtTheClosedFormStep) {
  const auto model = test::load_model("qdrone2");
  const CollisionShape& s = model->collision_shape();
  ASSERT_EQ(s.kind, CollisionShape::Kind::kSphere);
  // Largest rotor-hub distance + 0.1 m.
  double hub_m = 0.0;
  for (int i = 0; i < model->num_rotors(); ++i)
    hub_m = std::max(hub_m, model->rotor(i).position_m.norm());
  EXPECT_DOUBLE_EQ(s.radius_m, hub_m + 0.1);
  expect_collision_at_the_closed_form_step(model);
}

TEST(SimulatorScene, ABoxFromTheModelHitsTheWallAtTheClosedFormStep) {
  VehicleSpec spec = test::load_model("qdrone2")->spec();
  spec.collision = CollisionShape::box(Vec3(0.3, 0.25, 0.06), Vec3(0.05, 0.0, 0.02));
  expect_collision_at_the_closed_form_step(std::make_shared<const VehicleModel>(spec));
}

TEST(SimulatorScene, WithoutASceneNothingIsTouched) {
  const auto model = test::load_model("qdrone2");
  Simulator sim(model, no_gravity());
  start(sim);
  EXPECT_TRUE(sim.step(3000).ok());
  EXPECT_GT(sim.state()[0], kWallFace_m);
  EXPECT_EQ(sim.scene(), nullptr);
}

TEST(SimulatorScene, BadCollisionShapesAreRefusedNamingTheField) {
  VehicleSpec spec = test::load_model("qdrone2")->spec();
  spec.collision = CollisionShape::sphere(0.0);
  EXPECT_THROW(
      {
        try {
          VehicleModel m(spec);
        } catch (const InvalidArgument& e) {
          EXPECT_NE(std::string(e.what()).find("collision.radius_m: expected > 0, got 0"),
                    std::string::npos)
              << e.what();
          throw;
        }
      },
      InvalidArgument);
  spec.collision = CollisionShape::box(Vec3(0.1, -0.1, 0.1));
  EXPECT_THROW(VehicleModel{spec}, InvalidArgument);
}

}  // namespace
}  // namespace dronetwin
