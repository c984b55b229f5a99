// Fleet experiments: one VehicleRun per vehicle, stepped together by a Fleet.
#include "dronetwin/app/run_fleet.hpp"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>

#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/fleet/fleet.hpp"
#include "dronetwin/logging/json_writer.hpp"
#include "dronetwin/logging/log_metadata.hpp"
#include "dronetwin/logging/output_folder.hpp"
#include "dronetwin/logging/text_file.hpp"
#include "vehicle_run.hpp"

namespace dronetwin {

namespace {

/// Forwards to a vehicle's run observer and keeps the downwash statistics of every step.
class DownwashStatistics final : public LoopObserver {
 public:
  DownwashStatistics(LoopObserver& inner, FleetVehicleSummary& summary)
      : inner_(inner), s_(summary) {}
  void observe(const ClosedLoop& loop) override {
    const SimData& d = loop.simulator().data();
    s_.max_downwash_flow_m_s = std::max(s_.max_downwash_flow_m_s, d.interaction_flow_W_m_s.norm());
    s_.max_thrust_loss_N = std::max(s_.max_thrust_loss_N, -d.interaction_wrench_B[2]);
    inner_.observe(loop);
  }
  void finish(const ClosedLoop& loop, const StepResult& result) override {
    inner_.finish(loop, result);
  }

 private:
  LoopObserver& inner_;
  FleetVehicleSummary& s_;
};

}  // namespace

FleetRunSummary run_fleet_experiment(const FleetExperiment& f, const std::string& out_dir,
                                     bool overwrite, const RunProgressFn& progress) {
  require(!f.vehicles.empty(), f.source, ": vehicles: expected at least one vehicle");
  Fleet fleet(f.downwash);  // checks the settings
  OutputFolder out(out_dir, {"fleet_summary.json"}, {f.source}, overwrite, "fleet run");
  FleetRunSummary s;
  s.experiment_name = f.name;
  s.experiment_path = f.source;
  s.downwash = f.downwash;
  s.vehicles.resize(f.vehicles.size());
  std::vector<std::unique_ptr<app_detail::VehicleRun>> runs;
  std::vector<std::unique_ptr<DownwashStatistics>> statistics;
  for (std::size_t i = 0; i < f.vehicles.size(); ++i) {
    const FleetVehicleSpec& v = f.vehicles[i];
    validate(v.experiment);
    const std::string text = read_text_file(v.experiment.model_path, "model file");
    auto model = std::make_shared<const VehicleModel>(
        VehicleModel(parse_vehicle_spec(text, v.experiment.model_path)));
    const std::string folder = (std::filesystem::path(out_dir) / v.name).string();
    runs.push_back(std::make_unique<app_detail::VehicleRun>(
        v.experiment, std::move(model), folder, overwrite, content_hash(text),
        /*interaction_columns=*/true, std::vector<std::string>{f.source}));
    s.vehicles[i].name = v.name;
    s.vehicles[i].folder = folder;
    statistics.push_back(std::make_unique<DownwashStatistics>(runs[i]->observer(), s.vehicles[i]));
    fleet.add(v.name, runs[i]->simulator(), runs[i]->loop(), statistics[i].get());
  }
  if (const auto [i, j] = fleet.find_contact(); i >= 0) {
    throw InvalidArgument(
        detail::concat(f.source, ": vehicles: '", fleet.name(i), "' and '", fleet.name(j),
                       "' start in contact (their collision spheres overlap: centres closer than ",
                       fleet.contact_distance_m(i, j), " m)"));
  }
  // The vehicles step in lockstep: the first one's clock is the fleet's.
  runs.front()->set_progress(progress);
  const auto start = std::chrono::steady_clock::now();
  const FleetResult result = fleet.run(f.duration_s);
  s.wall_clock_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  s.steps_requested = f.vehicles.front().experiment.num_steps();
  s.steps = result.steps_taken;
  s.duration_s = fleet.simulator(0).time_s();
  s.status = result.status;
  s.failure_message = result.failure_message;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const int k = static_cast<int>(i);
    StepResult r{StepStatus::kOk, result.steps_taken};
    std::string collided_with;
    if (k == result.failed_vehicle) r.status = result.status;
    if (result.status == StepStatus::kCollided &&
        (k == result.failed_vehicle || k == result.other_vehicle)) {
      r.status = StepStatus::kCollided;
      collided_with =
          "vehicle '" +
          fleet.name(k == result.failed_vehicle ? result.other_vehicle : result.failed_vehicle) +
          "'";
    }
    s.vehicles[i].run = runs[i]->finish(r, collided_with);
  }
  s.summary_path = out.final_path("fleet_summary.json").string();
  write_text_file(out.partial("fleet_summary.json"), fleet_summary_to_json(s));
  out.commit();
  return s;
}

std::string fleet_summary_to_json(const FleetRunSummary& s) {
  using json::JsonObject;
  JsonObject downwash(2);
  downwash.boolean("enabled", s.downwash.enabled)
      .num("spreading_rate", s.downwash.spreading_rate)
      .num("propeller_radius_m", s.downwash.propeller_radius_m)
      .num("thrust_lapse", s.downwash.thrust_lapse)
      .num("air_density_kg_m3", s.downwash.air_density_kg_m3);
  std::string vehicles = "[";
  for (std::size_t i = 0; i < s.vehicles.size(); ++i) {
    const FleetVehicleSummary& v = s.vehicles[i];
    JsonObject one(4);
    one.str("name", v.name)
        .str("folder", v.folder)
        .str("status", status_name(v.run.status))
        .str("collided_with", v.run.collided_with)
        .num("max_downwash_flow_m_s", v.max_downwash_flow_m_s)
        .num("max_thrust_loss_N", v.max_thrust_loss_N);
    if (v.run.closed_loop) {
      const Vec4& e = v.run.closed_loop->rmse;
      JsonObject rmse(6);
      rmse.num("x", e[0]).num("y", e[1]).num("z", e[2]).num("yaw", e[3]);
      one.raw("rmse", rmse.done());
    }
    one.num("min_z_m", v.run.min_z_m).str("summary_path", v.run.summary_path);
    vehicles += (i ? ", " : "") + one.done();
  }
  JsonObject j(0);
  j.str("dronetwin_version", std::string(version()))
      .str("experiment", s.experiment_name)
      .str("experiment_path", s.experiment_path)
      .raw("downwash", downwash.done())
      .integer("steps_requested", s.steps_requested)
      .integer("steps", s.steps)
      .num("duration_s", s.duration_s)
      .str("status", status_name(s.status))
      .str("failure_message", s.failure_message)
      .raw("vehicles", vehicles + "]")
      .num("wall_clock_s", s.wall_clock_s);
  return j.done() + "\n";
}

}  // namespace dronetwin
