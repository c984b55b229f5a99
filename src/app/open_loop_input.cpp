// Open-loop experiment inputs as a controller (open_loop_input.hpp).
#include "dronetwin/app/open_loop_input.hpp"

#include <cmath>
#include <variant>

#include "dronetwin/core/error.hpp"

namespace dronetwin {
namespace {
template <class... Fs>
struct Overloaded : Fs... {
  using Fs::operator()...;
};
template <class... Fs>
Overloaded(Fs...) -> Overloaded<Fs...>;
}  // namespace

OpenLoopInput::OpenLoopInput(const Experiment& e, std::shared_ptr<const VehicleModel> model)
    : ControllerBase(std::move(model)), dt_s_(e.sim.dt_s) {
  const VehicleModel& m = this->model();
  const double g = e.gravity_magnitude();
  // One lambda per input kind: a kind added to ExperimentInput without one does not compile.
  std::visit(Overloaded{
                 [&](const ConstantRotorSpeedsInput& c) {
                   schedule_.push_back({0, c.rotor_speeds.resolve(m, g)});
                 },
                 [&](const PiecewiseRotorSpeedsInput& p) {
                   for (const RotorSpeedSegment& s : p.segments)
                     schedule_.push_back(
                         {segment_start_step(s.start_s, dt_s_), s.rotor_speeds.resolve(m, g)});
                 },
                 [&](const ConstantGeneralizedForceInput& u) {
                   force_ = u.u;
                   use_force_ = true;
                   set_allocation(u.allocation);
                 },
                 [&](const HoverInput&) {
                   schedule_.push_back({0, m.hover_speeds_rad_s(g)});
                 },
                 [&](const ControllerLoopInput&) {
                   require(false, e.source,
                           ": input: a controller input is flown by its controller, not as an "
                           "open-loop input");
                 },
             },
             e.input);
}

GeneralizedForce OpenLoopInput::do_calculate_u(const ControlInput&) { return force_; }

RotorVector OpenLoopInput::do_calculate_actuator_cmd(const ControlInput& in) {
  if (use_force_) return ControllerBase::do_calculate_actuator_cmd(in);
  const std::int64_t k = std::llround(in.time_s / dt_s_);
  const RotorVector* command = &schedule_.front().reference_rad_s;
  for (const Entry& entry : schedule_) {
    if (entry.start_step > k) break;
    command = &entry.reference_rad_s;
  }
  return *command;
}

}  // namespace dronetwin
