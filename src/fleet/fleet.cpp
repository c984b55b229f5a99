#include "dronetwin/fleet/fleet.hpp"

#include <optional>
#include <utility>

#include "dronetwin/core/error.hpp"
#include "dronetwin/math/quaternion.hpp"

namespace dronetwin {

namespace {

/// Centre (world frame) and radius of the sphere standing for a vehicle in vehicle-vehicle
/// contact: its collision sphere, or the sphere around its collision box.
std::pair<Vec3, double> contact_sphere(const Simulator& sim) {
  const CollisionShape& c = sim.model().collision_shape();
  const StateVector& x = sim.state();
  const Mat3 R = math::rotation_matrix<double>(Vec4(x.segment<4>(state_index::kQuaternion)));
  const double radius_m =
      c.kind == CollisionShape::Kind::kSphere ? c.radius_m : c.half_size_m.norm();
  return {x.segment<3>(state_index::kPosition) + R * c.center_B_m, radius_m};
}

}  // namespace

Fleet::Fleet(DownwashSettings downwash) : downwash_(downwash) {
  const DownwashSettings& d = downwash_;
  require(std::isfinite(d.spreading_rate) && d.spreading_rate > 0.0,
          "downwash.spreading_rate: expected a number > 0, got ", d.spreading_rate);
  require(std::isfinite(d.propeller_radius_m) && d.propeller_radius_m > 0.0,
          "downwash.propeller_radius_m: expected a number > 0, got ", d.propeller_radius_m);
  require(std::isfinite(d.thrust_lapse) && d.thrust_lapse >= 0.0,
          "downwash.thrust_lapse: expected a number >= 0, got ", d.thrust_lapse);
  require(std::isfinite(d.air_density_kg_m3) && d.air_density_kg_m3 > 0.0,
          "downwash.air_density_kg_m3: expected a number > 0, got ", d.air_density_kg_m3);
}

int Fleet::add(std::string name, Simulator& sim, ClosedLoop& loop, LoopObserver* observer) {
  require(!name.empty(), "Fleet::add: a vehicle needs a name");
  for (const Vehicle& v : vehicles_)
    require(v.name != name, "Fleet::add: two vehicles are called '", name, "'");
  require(&loop.simulator() == &sim, "Fleet::add: vehicle '", name,
          "': its ClosedLoop flies another simulator");
  if (!vehicles_.empty()) {
    const double dt0 = vehicles_.front().sim->config().dt_s;
    require(sim.config().dt_s == dt0, "Fleet::add: vehicle '", name,
            "' steps with dt = ", sim.config().dt_s, " s, but '", vehicles_.front().name, "' with ",
            dt0, " s: a fleet steps in lockstep");
  }
  Vehicle v;
  v.name = std::move(name);
  v.sim = &sim;
  v.loop = &loop;
  v.observer = observer;
  vehicles_.push_back(std::move(v));
  wakes_.resize(vehicles_.size());
  others_.reserve(vehicles_.size());
  return size() - 1;
}

double Fleet::contact_distance_m(int i, int j) const {
  return contact_sphere(simulator(i)).second + contact_sphere(simulator(j)).second;
}

void Fleet::apply_downwash() {
  const std::size_t n = vehicles_.size();
  if (!downwash_.enabled || n < 2) return;
  for (std::size_t k = 0; k < n; ++k) {
    const Simulator& s = *vehicles_[k].sim;
    wakes_[k] = wake_source(downwash_, s.model(), s.state(), s.rotor_speeds_rad_s());
  }
  for (std::size_t k = 0; k < n; ++k) {
    Vehicle& v = vehicles_[k];
    others_.clear();
    for (std::size_t j = 0; j < n; ++j)
      if (j != k) others_.push_back(wakes_[j]);
    v.downwash =
        downwash_effect(downwash_, v.sim->model(), v.sim->state(), v.sim->rotor_speeds_rad_s(),
                        others_.data(), static_cast<int>(others_.size()));
    v.sim->set_interaction(v.downwash.flow_W_m_s, v.downwash.wrench_B);
  }
}

std::pair<int, int> Fleet::find_contact() const {
  for (int i = 0; i < size(); ++i) {
    const auto [ci, ri] = contact_sphere(simulator(i));
    for (int j = i + 1; j < size(); ++j) {
      const auto [cj, rj] = contact_sphere(simulator(j));
      if ((ci - cj).norm() < ri + rj) return {i, j};
    }
  }
  return {-1, -1};
}

FleetResult Fleet::run(double duration_s) {
  require(!vehicles_.empty(), "Fleet::run: the fleet has no vehicles");
  return run_holding(0, duration_s);
}

FleetResult Fleet::run_holding(std::size_t i, double duration_s) {
  // Holds are neither copied nor moved: one stack frame per vehicle keeps its two.
  if (i == vehicles_.size()) return run_held(duration_s);
  const auto sim_in_use = vehicles_[i].sim->exclusive_use("Fleet::run (a vehicle's simulator)");
  const auto controller_in_use =
      vehicles_[i].loop->controller().exclusive_use("Fleet::run (a vehicle's controller)");
  return run_holding(i + 1, duration_s);
}

FleetResult Fleet::run_held(double duration_s) {
  const std::int64_t n = ClosedLoop::steps_for(duration_s, vehicles_.front().sim->config().dt_s);
  for (Vehicle& v : vehicles_) v.result = StepResult{};
  FleetResult fleet;
  const auto fail = [&](int i, StepStatus status, std::string message) {
    fleet.status = status;
    fleet.failed_vehicle = i;
    fleet.failure_message =
        "vehicle '" + vehicles_[static_cast<std::size_t>(i)].name + "': " + std::move(message);
    vehicles_[static_cast<std::size_t>(i)].result.status = status;
  };
  // The controllers at t = 0, then every observer.
  const auto update_all = [&]() {
    for (int i = 0; i < size(); ++i) {
      Vehicle& v = vehicles_[static_cast<std::size_t>(i)];
      if (!v.loop->try_update()) {
        fail(i, StepStatus::kControllerFailed, v.loop->failure_message());
        return false;
      }
    }
    for (Vehicle& v : vehicles_)
      if (v.observer != nullptr) v.observer->observe(*v.loop);
    return true;
  };
  if (update_all()) {
    for (std::int64_t k = 0; k < n && fleet.ok(); ++k) {
      apply_downwash();
      for (int i = 0; i < size(); ++i) {
        Vehicle& v = vehicles_[static_cast<std::size_t>(i)];
        const StepResult r = v.loop->step();
        if (!r.ok()) {
          fail(i, r.status, v.sim->failure_message());
          break;
        }
      }
      if (!fleet.ok()) break;
      ++fleet.steps_taken;
      for (Vehicle& v : vehicles_) ++v.result.steps_taken;
      if (const auto [i, j] = find_contact(); i >= 0) {
        const auto& a = vehicles_[static_cast<std::size_t>(i)];
        const auto& b = vehicles_[static_cast<std::size_t>(j)];
        const Vec3 d = b.sim->state().segment<3>(state_index::kPosition) -
                       a.sim->state().segment<3>(state_index::kPosition);
        fail(i, StepStatus::kCollided,
             detail::concat("touched vehicle '", b.name, "' at t = ", a.sim->time_s(),
                            " s: centres ", d.norm(), " m apart, contact below ",
                            contact_distance_m(i, j), " m"));
        fleet.other_vehicle = j;
        vehicles_[static_cast<std::size_t>(j)].result.status = StepStatus::kCollided;
        break;
      }
      if (!update_all()) break;
    }
  }
  for (Vehicle& v : vehicles_)
    if (v.observer != nullptr) v.observer->finish(*v.loop, v.result);
  return fleet;
}

}  // namespace dronetwin
