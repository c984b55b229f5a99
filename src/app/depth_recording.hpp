#pragma once
// The depth cameras of a run (Experiment::depth_cameras): each renders the scene at its rate,
// from the vehicle's true state at the steps sample_schedule.hpp gives, into <name>.npy of the
// output folder (float32, shape (frames, height, width)). Frames stream to the file: memory is
// one frame per camera whatever the run's length. Private to app/run_experiment.cpp.

#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "dronetwin/logging/npy_writer.hpp"
#include "dronetwin/logging/output_folder.hpp"
#include "dronetwin/noise/random.hpp"
#include "dronetwin/sensors/depth_camera.hpp"
#include "dronetwin/sensors/sample_schedule.hpp"
#include "dronetwin/sim/simulator.hpp"

namespace dronetwin {

class DepthRecording {
 public:
  DepthRecording(const std::vector<DepthCameraSpec>& specs, std::uint64_t seed, double dt_s,
                 const OutputFolder& out)
      : dt_s_(dt_s) {
    cameras_.reserve(specs.size());
    for (const DepthCameraSpec& s : specs) {
      const DepthCameraParameters& p = s.parameters;
      cameras_.push_back(Camera{s, DepthCamera(p), Random(sensor_stream_seed(seed, s.name)),
                                std::make_unique<NpyFrameWriter>(out.partial(file_name(s)).string(),
                                                                 p.height_px, p.width_px),
                                std::vector<float>(static_cast<std::size_t>(p.width_px) *
                                                   static_cast<std::size_t>(p.height_px))});
    }
  }

  static std::string file_name(const DepthCameraSpec& s) { return s.name + ".npy"; }

  /// At every step (and step 0): the frames due now.
  void record(const Simulator& sim) {
    const std::int64_t step = sim.step_count();
    for (Camera& c : cameras_) {
      if (step < c.next_step) continue;
      const bool noisy = c.spec.parameters.noise_at_1m_m > 0.0;
      c.camera.render(sim.state(), sim.scene(), c.frame.data(), noisy ? &c.rng : nullptr);
      c.out->append(c.frame.data());
      c.stamp_s = sim.time_s();
      c.index = static_cast<double>(c.out->frames() - 1);
      c.next_step =
          std::max(step + 1, step_of_sample(c.out->frames(), c.spec.parameters.rate_hz, dt_s_));
    }
  }

  /// The log's <name>_t and <name>_frame, camera after camera.
  template <class Out>
  void write_columns(Out& row, std::size_t& k) const {
    for (const Camera& c : cameras_) {
      row[k++] = c.stamp_s;
      row[k++] = c.index;
    }
  }

  /// Finishes every file (the final headers). InvalidArgument naming a file that failed.
  void close() {
    for (Camera& c : cameras_) c.out->close();
  }

  std::size_t size() const { return cameras_.size(); }
  const DepthCameraSpec& spec(std::size_t i) const { return cameras_[i].spec; }
  std::int64_t frames(std::size_t i) const { return cameras_[i].out->frames(); }

 private:
  struct Camera {
    DepthCameraSpec spec;
    DepthCamera camera;
    Random rng;
    std::unique_ptr<NpyFrameWriter> out;
    std::vector<float> frame;
    std::int64_t next_step = 0;
    double stamp_s = std::numeric_limits<double>::quiet_NaN();
    double index = std::numeric_limits<double>::quiet_NaN();
  };
  double dt_s_;
  std::vector<Camera> cameras_;
};

}  // namespace dronetwin
