#pragma once
// ControllerBase: the interface every controller implements (thesis Sec. 3.5).
//
// A controller maps the measured state X, its derivative X_dot and a reference to either
//   - generalized forces u = [T, tau_x, tau_y, tau_z]      (calculate_u, thesis Sec. 3.5.2), or
//   - rotor speed references                              (calculate_actuator_cmd, Sec. 3.5.3).
// A controller that implements only calculate_u is allocated automatically through the vehicle
// model (thrust-first exact allocation, or the thesis's Eq. 2.31).
//
//   class Hover : public ControllerBase {
//    public:
//     using ControllerBase::ControllerBase;
//     std::string_view name() const override { return "hover"; }
//     std::unique_ptr<ControllerBase> clone() const override { return
//     std::make_unique<Hover>(*this); }
//    protected:
//     GeneralizedForce do_calculate_u(const ControlInput& in) override { ... }
//   };
//
// The public entry points are non-virtual: they validate the inputs, call the protected
// do_* implementation, and check the output is finite and correctly sized (a controller bug is
// reported with the controller's name, never flown).

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "dronetwin/control/reference.hpp"
#include "dronetwin/core/single_thread.hpp"
#include "dronetwin/core/types.hpp"
#include "dronetwin/model/allocation.hpp"
#include "dronetwin/model/vehicle_model.hpp"

namespace dronetwin {

/// A slung payload as a controller sees it (payload/slung_payload.hpp): its position and
/// velocity, world frame, as a motion-capture marker on the load gives them (true values).
/// `available` is false when the simulator flies no payload.
struct PayloadObservation {
  bool available = false;
  Vec3 position_W_m = Vec3::Zero();
  Vec3 velocity_W_m_s = Vec3::Zero();
};

/// What a controller sees at one control step.
struct ControlInput {
  double time_s = 0.0;
  StateVector state = StateVector::Zero();             ///< measured X (noisy when noise is on)
  StateVector state_derivative = StateVector::Zero();  ///< measured X_dot
  ReferencePoint reference{};
  PayloadObservation payload{};
};

enum class ControlLevel {
  kGeneralizedForce,  ///< the controller implements calculate_u; dronetwin allocates
  kRotorSpeed,        ///< the controller implements calculate_actuator_cmd itself
};

class ControllerBase {
 public:
  ControllerBase(std::shared_ptr<const VehicleModel> model,
                 AllocationMethod allocation = AllocationMethod::kExact);
  virtual ~ControllerBase() = default;

  virtual std::string_view name() const = 0;
  virtual ControlLevel level() const { return ControlLevel::kGeneralizedForce; }
  virtual std::unique_ptr<ControllerBase> clone() const = 0;
  /// Clears internal memory (integrators, previous errors) before a new run.
  virtual void reset() {}
  /// False for controllers that ignore ControlInput::state_derivative (open-loop schedules): the
  /// loop then leaves it zero instead of evaluating the force model for it.
  virtual bool uses_state_derivative() const { return true; }

  /// Diagnostics: names of per-update values a controller reports (an NMPC's solve statistics,
  /// say). The experiment runner logs them as `ctrl_<name>` columns and summarises them in
  /// summary.json. Empty (the default) for controllers without diagnostics.
  virtual std::vector<std::string> diagnostic_names() const { return {}; }
  /// Writes the values of the most recent update, in the order of diagnostic_names(), to `out`
  /// (room for diagnostic_names().size() values). NaN means "not applicable at this update"
  /// (e.g. no solve ran) and is left out of the summary statistics.
  virtual void diagnostics(double* out) const { (void)out; }

  /// Gives a controller that looks ahead (NMPC) the whole reference, not just the point at the
  /// current instant. ClosedLoop calls it with the reference it flies; the default ignores it.
  /// A controller keeps its own copy (Reference::clone()).
  virtual void set_reference_preview(const Reference& reference) { (void)reference; }

  /// Generalized forces [T, tau_x, tau_y, tau_z] (thesis Sec. 3.5.2). Throws InvalidArgument for
  /// non-finite inputs and SimulationError when the controller returns non-finite values.
  GeneralizedForce calculate_u(const ControlInput& in);
  /// Rotor speed references (thesis Sec. 3.5.3). For kGeneralizedForce controllers this is
  /// calculate_u followed by the allocation; last_allocation() then tells about saturation.
  RotorVector calculate_actuator_cmd(const ControlInput& in);

  const VehicleModel& model() const { return *model_; }
  const std::shared_ptr<const VehicleModel>& model_ptr() const { return model_; }
  AllocationMethod allocation() const { return allocation_; }
  void set_allocation(AllocationMethod m) { allocation_ = m; }
  /// The most recent allocation (kGeneralizedForce controllers), for logs and saturation stats.
  const AllocationResult& last_allocation() const { return last_allocation_; }

  /// Marks the controller in use by this thread for the returned object's lifetime (ClosedLoop::run
  /// takes it once). A controller has memory (integrators, plans): two threads calling it at once
  /// get a SimulationError instead of a mixed state. calculate_u() and calculate_actuator_cmd()
  /// take it too.
  [[nodiscard]] SingleThreadGuard::Hold exclusive_use(const char* what) const {
    return SingleThreadGuard::Hold(guard_, what);
  }

 protected:
  virtual GeneralizedForce do_calculate_u(const ControlInput& in);
  virtual RotorVector do_calculate_actuator_cmd(const ControlInput& in);

 private:
  void check_input(const ControlInput& in) const;

  std::shared_ptr<const VehicleModel> model_;
  AllocationMethod allocation_;
  AllocationResult last_allocation_;
  SingleThreadGuard guard_;
};

}  // namespace dronetwin
