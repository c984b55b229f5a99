// Soak: a QDrone2 hovering under the tuned PID at 1 kHz with the thesis's OU measurement noise for
// many steps (1e8 by default: 27.8 h of flight), checking as it goes that nothing drifts beyond
// what the noise explains and no NaN appears. Not a unit test (it takes about two minutes); run:
//
//   build/release/bench/soak [--steps N] [--seed S]
//
// Expectation, from the noise model: the controller sees the true state plus OU noise, so the
// true position wanders like the measurement noise filtered by the closed loop. The bound is
// 10 x the stationary standard deviation of the OU position noise, computed here from its
// parameters (discrete Lyapunov equation P = A P A^T + B B^T, A = I - Theta, B = sqrt(dt) Sigma);
// and the RMS error of the last 10 % of the run may not exceed that of the first 10 % by more
// than 25 % (no slow drift). Exit code 0 when both hold and every step was ok.

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include "dronetwin/app/controller_registry.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/control/closed_loop.hpp"
#include "dronetwin/noise/ornstein_uhlenbeck.hpp"

namespace {

using namespace dronetwin;

/// Stationary standard deviation of the OU noise on the x position.
double stationary_position_sigma(const OuParameters& p, double dt_s) {
  using Mat13 = Eigen::Matrix<double, kStateSize, kStateSize>;
  const double s = p.drift == OuDrift::kPerSample ? 1.0 : dt_s;
  const Mat13 A = Mat13::Identity() - s * ou_block_matrix(p.theta);
  const Mat13 B = std::sqrt(dt_s) * ou_block_matrix(p.sigma);
  Mat13 P = Mat13::Zero();
  for (int k = 0; k < 200000; ++k) {
    const Mat13 next = A * P * A.transpose() + B * B.transpose();
    if ((next - P).norm() <= 1e-15 * next.norm()) return std::sqrt(next(0, 0));
    P = next;
  }
  return std::sqrt(P(0, 0));
}

struct Watch final : LoopObserver {
  Vec3 target;
  std::int64_t steps = 0, total = 0;
  double max_error = 0.0, first_sq = 0.0, last_sq = 0.0;
  std::int64_t first_n = 0, last_n = 0;
  bool finite = true;
  void observe(const ClosedLoop& loop) override {
    const StateVector& x = loop.simulator().state();
    finite = finite && x.allFinite() && loop.simulator().measured_state().allFinite();
    const double e = (x.head<3>() - target).norm();
    if (e > max_error) max_error = e;
    if (steps < total / 10) {
      first_sq += e * e;
      ++first_n;
    } else if (steps >= total - total / 10) {
      last_sq += e * e;
      ++last_n;
    }
    ++steps;
  }
};

}  // namespace

int main(int argc, char** argv) {
  std::int64_t steps = 100'000'000;
  std::uint64_t seed = 1;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--steps") steps = std::atoll(argv[i + 1]);
    if (flag == "--seed") seed = std::strtoull(argv[i + 1], nullptr, 10);
  }
  const std::string root = DRONETWIN_SOURCE_DIR;
  auto model =
      std::make_shared<const VehicleModel>(load_vehicle_model(root + "/models/qdrone2.yaml"));
  SimConfig config;
  config.noise.enabled = true;
  config.seed = seed;
  Simulator sim(model, config);
  const Vec3 target(0.0, 0.0, 1.0);
  sim.reset(Simulator::hover_state(target), model->hover_speeds_rad_s());
  auto controller = load_controller(root + "/config/controllers/pid_tuned.yaml", model, 1000.0);
  const SetpointReference reference(target);
  ClosedLoop loop(sim, *controller, reference, 1000.0);
  Watch watch;
  watch.target = target;
  watch.total = steps + 1;
  const StepResult r = loop.run(static_cast<double>(steps) * config.dt_s, &watch);

  const double sigma = stationary_position_sigma(config.noise.parameters, config.dt_s);
  const double bound = 10.0 * sigma;
  const double first_rms = std::sqrt(watch.first_sq / static_cast<double>(watch.first_n));
  const double last_rms = std::sqrt(watch.last_sq / static_cast<double>(watch.last_n));
  const bool ok = r.ok() && r.steps_taken == steps && watch.finite && watch.max_error <= bound &&
                  last_rms <= 1.25 * first_rms;
  std::printf(
      "soak: %lld steps (%.1f h simulated), status %s, every state finite: %s\n"
      "  position error: max %.3g m (bound 10 sigma = %.3g m, sigma of the OU position noise "
      "%.3g m)\n"
      "  RMS error: first 10 %% %.3g m, last 10 %% %.3g m (ratio %.3f, bound 1.25)\n"
      "  %s\n",
      static_cast<long long>(r.steps_taken), static_cast<double>(r.steps_taken) * 1e-3 / 3600.0,
      std::string(status_name(r.status)).c_str(), watch.finite ? "yes" : "NO", watch.max_error,
      bound, sigma, first_rms, last_rms, last_rms / first_rms, ok ? "PASS" : "FAIL");
  return ok ? 0 : 1;
}
