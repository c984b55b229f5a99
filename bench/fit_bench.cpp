// Fit time of `dronetwin fit` (issue "Flight logs and parameter identification", item 6): a 60 s
// identification flight at 1 kHz (config/experiments/identification_flight.yaml, 60 001 rows) of
// the QDrone2 with 13 parameters changed by +-20 %, fitted back from the unchanged model on one
// thread. Flying the log and reading it happen once, outside the timing; each iteration is one
// fit_model() call from the starting model (both stages, covariance and residual statistics
// included). Variants: equation error (13 parameters: thrust, inertia, rotor and body drag,
// yaw moment, motor lag), the same with output error (200 windows of 50 ms), and a 3-parameter
// equation-error fit.
//
// The 1-hour log (issue "Reliability", item 2: a 1-hour log at 1 kHz fitted in < 60 s with
// <= 300 bytes per log row): the same 60 s flight 60 times over, each repeat after a 10 ms gap
// (3 600 060 rows at 1 kHz; the fit leaves the 59 gaps out, as it would a real log's), fitted
// with the default options on 1 and 2 threads (and once without the coarse start,
// FitOptions::coarse_intervals = 0). Counters: data_bytes_per_row (FlightData::bytes()
// / rows) and max_rss_bytes_per_row (the process' peak resident memory after the fit / rows:
// everything, the log, the fit's scratch, the libraries).
// Run: build/release/bench/fit_bench --benchmark_repetitions=3 --benchmark_filter=60s
//      build/release/bench/fit_bench --benchmark_filter=1h
#include <benchmark/benchmark.h>
#include <sys/resource.h>

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

// `defaults`: the options as shipped (auto channels, Huber loss, speed-sensor gains with the
// angular channel); otherwise the options of the fit before the issue "Reliability" (least
// squares, both channels, no gains), to compare with the earlier numbers.
void fit(benchmark::State& state, const char* params, FitMethod method, bool defaults) {
  const Data& d = data();
  FitOptions o;
  o.parameters = parse_parameter_list(params);
  o.method = method;
  if (!defaults) {
    o.loss = FitLoss::kNone;
    o.channels = FitChannels::kLinearAngular;
    o.speed_sensor_gains = SpeedSensorGains::kOff;
  }
  FitResult r;
  for (auto _ : state) {
    r = fit_model(*d.nominal, d.flight, o);
    benchmark::DoNotOptimize(r.parameters.data());
  }
  state.counters["rows"] = static_cast<double>(d.flight.rows());
  state.counters["parameters"] = static_cast<double>(r.parameters.size());
  state.counters["iterations"] = r.iterations;
}

// The 60 s flight repeated 60 times, 10 ms apart (see the top of the file).
const FlightData& hour() {
  static const FlightData h = [] {
    const FlightData& f = data().flight;
    FlightData out("60 x " + f.source(), f.layout());
    out.reserve(60 * f.rows());
    const double period = f.t_s(f.rows() - 1) - f.t_s(0) + 0.010;
    for (int repeat = 0; repeat < 60; ++repeat) {
      for (std::size_t k = 0; k < f.rows(); ++k) {
        out.append_row(f.t_s(k) + repeat * period, f.state(k), f.rotor_speeds_rad_s(k),
                       f.has_rotor_references() ? f.rotor_references_rad_s(k) : nullptr,
                       f.in_contact(k));
      }
    }
    return out;
  }();
  return h;
}

void fit_hour(benchmark::State& state, const char* params, FitMethod method, int threads,
              std::size_t coarse_intervals = FitOptions{}.coarse_intervals) {
  const FlightData& h = hour();
  FitOptions o;
  o.parameters = parse_parameter_list(params);
  o.method = method;
  o.num_threads = threads;
  o.coarse_intervals = coarse_intervals;
  FitResult r;
  for (auto _ : state) {
    r = fit_model(*data().nominal, h, o);
    benchmark::DoNotOptimize(r.parameters.data());
  }
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto rows = static_cast<double>(h.rows());
  state.counters["rows"] = rows;
  state.counters["gaps"] = static_cast<double>(r.gaps);
  state.counters["iterations"] = r.iterations;
  state.counters["coarse_stride"] = static_cast<double>(r.coarse_stride);
  state.counters["data_bytes_per_row"] = static_cast<double>(h.bytes()) / rows;
  state.counters["max_rss_bytes_per_row"] = 1024.0 * static_cast<double>(usage.ru_maxrss) / rows;
}

const char* kThirteen = "thrust,inertia,rotor_drag,yaw_moment_per_thrust,body_drag,motor";
const char* kThree = "thrust_k1,inertia_zz,body_drag_z";

void BM_Fit60sEquationError13(benchmark::State& s) {
  fit(s, kThirteen, FitMethod::kEquationError, false);
}
void BM_Fit60sBoth13(benchmark::State& s) { fit(s, kThirteen, FitMethod::kBoth, false); }
void BM_Fit60sEquationError3(benchmark::State& s) {
  fit(s, kThree, FitMethod::kEquationError, false);
}
void BM_Fit60sEquationError13Defaults(benchmark::State& s) {
  fit(s, kThirteen, FitMethod::kEquationError, true);
}
void BM_Fit60sBoth13Defaults(benchmark::State& s) { fit(s, kThirteen, FitMethod::kBoth, true); }
void BM_Fit60sEquationError3Defaults(benchmark::State& s) {
  fit(s, kThree, FitMethod::kEquationError, true);
}

void BM_Fit1hEquationError3Defaults(benchmark::State& s) {
  fit_hour(s, kThree, FitMethod::kEquationError, 1);
}
// The same without the coarse start: every iteration walks all 3.6 M intervals.
void BM_Fit1hEquationError3DefaultsAllIntervals(benchmark::State& s) {
  fit_hour(s, kThree, FitMethod::kEquationError, 1, 0);
}
void BM_Fit1hBoth3Defaults(benchmark::State& s) { fit_hour(s, kThree, FitMethod::kBoth, 1); }
void BM_Fit1hBoth3Defaults2Threads(benchmark::State& s) {
  fit_hour(s, kThree, FitMethod::kBoth, 2);
}
void BM_Fit1hBoth13Defaults2Threads(benchmark::State& s) {
  fit_hour(s, kThirteen, FitMethod::kBoth, 2);
}

BENCHMARK(BM_Fit60sEquationError13)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_Fit60sBoth13)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_Fit60sEquationError3)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_Fit60sEquationError13Defaults)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_Fit60sBoth13Defaults)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_Fit60sEquationError3Defaults)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_Fit1hEquationError3Defaults)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_Fit1hEquationError3DefaultsAllIntervals)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_Fit1hBoth3Defaults)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_Fit1hBoth3Defaults2Threads)->Unit(benchmark::kSecond)->Iterations(1);
BENCHMARK(BM_Fit1hBoth13Defaults2Threads)->Unit(benchmark::kSecond)->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
