// Fleet experiment files (config/fleet_experiment.hpp): the shipped crossing reads with its two
// vehicles and settings; every mistake names the file, the field and what was expected.

#include "dronetwin/config/fleet_experiment.hpp"

#include <gtest/gtest.h>

#include <string>

#include "test_support.hpp"

namespace dronetwin {
namespace {

const std::string kDir = test::source_path("config/experiments");

TEST(FleetExperiment, TheShippedCrossingReads) {
  const FleetExperiment f = load_fleet_experiment(kDir + "/crossing_downwash.yaml");
  EXPECT_EQ(f.name, "crossing_downwash");
  EXPECT_EQ(f.duration_s, 12.0);
  EXPECT_TRUE(f.downwash.enabled);
  EXPECT_EQ(f.downwash.spreading_rate, 0.094);
  ASSERT_EQ(f.vehicles.size(), 2u);
  EXPECT_EQ(f.vehicles[0].name, "upper");
  EXPECT_EQ(f.vehicles[1].experiment.name, "crossing_lower");
  EXPECT_EQ(f.vehicles[1].experiment.duration_s, 12.0);
  EXPECT_FALSE(load_fleet_experiment(kDir + "/crossing_no_downwash.yaml").downwash.enabled);
  EXPECT_TRUE(looks_like_fleet_experiment("vehicles: []"));
  EXPECT_FALSE(looks_like_fleet_experiment("name: x\nduration_s: 1"));
  EXPECT_FALSE(looks_like_fleet_experiment("[unclosed"));
}

TEST(FleetExperiment, MistakesAreNamed) {
  test::TempDir dir;
  const std::string lower = kDir + "/crossing_lower.yaml";
  const std::string upper = kDir + "/crossing_upper.yaml";
  const auto error = [&](const std::string& text) {
    const std::string path = dir.write("fleet.yaml", text);
    return test::error_of([&] { (void)load_fleet_experiment(path); });
  };
  const std::string head = "name: f\nduration_s: 3\n";
  const std::string two = "vehicles:\n  - {name: a, experiment: " + upper +
                          "}\n  - {name: b, experiment: " + lower + "}\n";
  EXPECT_NE(error(head).find("vehicles"), std::string::npos);
  EXPECT_NE(error(head + "vehicles: []\n").find("vehicles: expected a list of vehicles"),
            std::string::npos);
  EXPECT_NE(error(head + "vehicle: []\n").find("vehicles"), std::string::npos);  // closest key
  EXPECT_NE(error("name: f\n" + two).find("duration_s"), std::string::npos);
  EXPECT_NE(error(head + "downwash: {spreading_rate: -1}\n" + two)
                .find("downwash.spreading_rate: expected a number > 0"),
            std::string::npos);
  EXPECT_NE(error(head + "downwash: {thrust_lapse: -0.5}\n" + two)
                .find("downwash.thrust_lapse: expected a thrust lapse >= 0, got -0.5"),
            std::string::npos);
  EXPECT_NE(error(head + "downwash: {thrust: 1}\n" + two).find("downwash"), std::string::npos);
  for (const std::string key : {"propeller_radius_m", "air_density_kg_m3"})
    EXPECT_NE(error(head + "downwash: {" + key + ": 0}\n" + two)
                  .find("downwash." + key + ": expected a number > 0"),
              std::string::npos)
        << key;
  EXPECT_NE(error(head + "downwash: maybe\n" + two).find("downwash"), std::string::npos);
  EXPECT_NE(error(head + "vehicles:\n  - {name: a, experiment: " + upper +
                  "}\n  - {name: a, experiment: " + lower + "}\n")
                .find("vehicles[1].name: two vehicles are called 'a'"),
            std::string::npos);
  EXPECT_NE(error(head + "vehicles:\n  - {name: a/b, experiment: " + upper + "}\n")
                .find("vehicles[0].name: expected a name usable as a folder"),
            std::string::npos);
  EXPECT_NE(error(head + "vehicles:\n  - {name: a, experiment: no_such.yaml}\n")
                .find("vehicles[0].experiment: experiment file 'no_such.yaml' not found"),
            std::string::npos);
  // A vehicle stepping at another rate cannot be in lockstep.
  const std::string coarse = dir.write(
      "coarse.yaml", "model: " + test::source_path("models/qdrone2.yaml") +
                         "\nname: coarse\nduration_s: 1\nphysics_dt_s: 0.002\n"
                         "initial_state: {position_m: [5, 5, 1]}\ninput: {type: hover}\n");
  EXPECT_NE(error(head + "vehicles:\n  - {name: a, experiment: " + upper +
                  "}\n  - {name: b, experiment: " + coarse + "}\n")
                .find("physics_dt_s of '" + coarse + "' is 0.002 s, but 0.001 s in"),
            std::string::npos);
  // A vehicle that paces at real time would hold the others back.
  const std::string paced = dir.write(
      "paced.yaml", "model: " + test::source_path("models/qdrone2.yaml") +
                        "\nname: paced\nduration_s: 1\n"
                        "input: {type: controller, controller: " +
                        test::source_path("config/controllers/se3.yaml") +
                        ", real_time: true, reference: {type: setpoint, position_m: [0, 0, 1]}}\n");
  EXPECT_NE(error(head + "vehicles:\n  - {name: a, experiment: " + paced + "}\n")
                .find("paces at real time (input.real_time): a fleet steps as fast as it can"),
            std::string::npos);
  // An error inside a vehicle's own file names that file.
  const std::string broken = dir.write("broken.yaml", "name: broken\nduration_s: -1\n");
  EXPECT_NE(error(head + "vehicles:\n  - {name: a, experiment: " + broken + "}\n").find(broken),
            std::string::npos);
}

}  // namespace
}  // namespace dronetwin
