// Fit time of `dronetwin fit` (issue "Flight logs and parameter identification", item 6): a 60 s
// identification flight at 1 kHz (config/experiments/identification_flight.yaml, 60 001 rows) of
// the QDrone2 with 13 parameters changed by +-20 %, fitted back from the unchanged model on one
// thread. Flying the log and reading it happen once, outside the timing; each iteration is one
// fit_model() call from the starting model (both stages, covariance and residual statistics
// included). Variants: equation error (13 parameters: thrust, inertia, rotor and body drag,
// yaw moment, motor lag), the same with output error (200 windows of 50 ms), and a 3-parameter
// equation-error fit.
// Run: build/release/bench/fit_bench --benchmark_repetitions=3
#include <benchmark/benchmark.h>

#include <filesystem>
#include <memory>
#include <string>

#include "dronetwin/app/run_experiment.hpp"
#include "dronetwin/config/experiment.hpp"
#include "dronetwin/config/model_loader.hpp"
#include "dronetwin/identification/fit.hpp"

namespace {

using namespace dronetwin;

struct Data {
  std::shared_ptr<const VehicleModel> nominal;
  FlightData flight;
};

const Data& data() {
  static const Data d = [] {
    const std::string root = DRONETWIN_SOURCE_DIR;
    Data out;
    out.nominal =
        std::make_shared<const VehicleModel>(load_vehicle_model(root + "/models/qdrone2.yaml"));
    VehicleSpec truth = out.nominal->spec();
    const std::pair<ModelParameter, double> changes[] = {
        {ModelParameter::kInertiaXX, 1.2}, {ModelParameter::kInertiaYY, 1.2},
        {ModelParameter::kInertiaZZ, 0.8}, {ModelParameter::kThrustK1, 0.8},
        {ModelParameter::kThrustK2, 1.2},  {ModelParameter::kThrustK3, 0.8},
        {ModelParameter::kRotorDrag, 1.2}, {ModelParameter::kYawMomentPerThrust, 0.8},
        {ModelParameter::kBodyDragX, 1.2}, {ModelParameter::kBodyDragY, 0.8},
        {ModelParameter::kBodyDragZ, 1.2}, {ModelParameter::kTauRise, 0.8},
        {ModelParameter::kTauFall, 1.2}};
    for (const auto& [p, f] : changes) set_parameter_value(truth, p, f * parameter_value(truth, p));
    const Experiment e = load_experiment(root + "/config/experiments/identification_flight.yaml");
    const auto dir = std::filesystem::temp_directory_path() / "dronetwin_fit_bench";
    (void)run_experiment(e, std::make_shared<const VehicleModel>(truth), dir.string());
    out.flight = flight_data_from_log(read_csv_log((dir / "log.csv").string()), 4);
    std::filesystem::remove_all(dir);
    return out;
  }();
  return d;
}

void fit(benchmark::State& state, const char* params, FitMethod method) {
  const Data& d = data();
  FitOptions o;
  o.parameters = parse_parameter_list(params);
  o.method = method;
  FitResult r;
  for (auto _ : state) {
    r = fit_model(*d.nominal, d.flight, o);
    benchmark::DoNotOptimize(r.parameters.data());
  }
  state.counters["rows"] = static_cast<double>(d.flight.t_s.size());
  state.counters["parameters"] = static_cast<double>(r.parameters.size());
  state.counters["iterations"] = r.iterations;
}

const char* kThirteen = "thrust,inertia,rotor_drag,yaw_moment_per_thrust,body_drag,motor";

void BM_Fit60sEquationError13(benchmark::State& s) { fit(s, kThirteen, FitMethod::kEquationError); }
void BM_Fit60sBoth13(benchmark::State& s) { fit(s, kThirteen, FitMethod::kBoth); }
void BM_Fit60sEquationError3(benchmark::State& s) {
  fit(s, "thrust_k1,inertia_zz,body_drag_z", FitMethod::kEquationError);
}

BENCHMARK(BM_Fit60sEquationError13)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_Fit60sBoth13)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_Fit60sEquationError3)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
