#pragma once
// VehicleModel: the immutable description of one multirotor airframe.
//
// Holds what a model file states (mass, inertia, rotors, body drag) plus constants derived from
// it once at construction and never typed in: J^-1, the allocation matrix (thesis Eq. 2.30
// generalised to N rotors with arbitrary positions and axes), its pseudo-inverse, the rotor
// wrench matrix, and the hover rotor speeds.
//
//   auto model = std::make_shared<const VehicleModel>(load_vehicle_model("models/qdrone2.yaml"));
//   std::cout << model->allocation_matrix() << "\n";      // 4 x N, Eq. 2.30
//   RotorVector w = model->hover_speeds_rad_s();          // exact thrust-polynomial inverse
//
// Trap: after construction nothing can change. To vary a parameter (a sweep, a fit), copy the
// `VehicleSpec`, edit it, and build a new VehicleModel, so the derived constants stay consistent.

#include <array>
#include <string>
#include <vector>

#include "dronetwin/core/types.hpp"
#include "dronetwin/model/rotor_params.hpp"

namespace dronetwin {

/// Everything a model file says, before validation. Plain data; edit freely, then build a
/// VehicleModel from it.
struct VehicleSpec {
  std::string name = "vehicle";
  /// Where this spec came from (a file path), used in error messages. Empty for code-built specs.
  std::string source;
  double mass_kg = 0.0;
  /// Full 3x3 inertia about the centre of mass, body frame, kg m^2 (thesis Table 2.1 / Eq. 2.39).
  Mat3 inertia_kgm2 = Mat3::Zero();
  /// Body (frame) aerodynamic drag matrix A: F_A = -A v_air (thesis Eq. 2.32), N s/m, applied in
  /// the body frame (see docs/conventions.md).
  Mat3 body_drag_Ns_per_m = Mat3::Zero();
  /// Floor for the rotor height h in the ground-effect term C_G T / h^2, m.
  double ground_effect_min_height_m = 0.023;
  std::vector<RotorParams> rotors;
};

/// 4 x N allocation matrix: [T; tau_x; tau_y; tau_z] = A * rotor thrusts.
using AllocationMatrix = Eigen::Matrix<double, 4, Eigen::Dynamic, Eigen::ColMajor, 4, kMaxRotors>;
/// N x 4 right pseudo-inverse of the allocation matrix.
using AllocationInverse = Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::ColMajor, kMaxRotors, 4>;
/// 6 x N rotor wrench matrix: [F_B; M_B] per unit thrust of each rotor.
using WrenchMatrix = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::ColMajor, 6, kMaxRotors>;
using WrenchInverse = Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::ColMajor, kMaxRotors, 6>;
using Matrix6 = Eigen::Matrix<double, 6, 6>;

/// Per-rotor geometric constants derived at load (used by the simulator's hot loop).
struct RotorGeometry {
  /// r_i x a_i: moment about the centre of mass of a unit force along the rotor axis.
  Vec3 arm_cross_axis = Vec3::Zero();
  /// [F_B; M_B] of the rotor drag per unit C_D |w| as a linear map of [v_air_B; w_B]:
  /// F = -P (v + w x r), M = r x F, with P = I - a a^T (Eq. 2.32-2.33).
  Matrix6 drag_map = Matrix6::Zero();
  /// [0; M_B] of the rolling moment per unit C_R |w|: M = P (v + w x r) (Eq. 2.32).
  Matrix6 rolling_map = Matrix6::Zero();
};

class VehicleModel {
 public:
  /// Validates `spec` and derives the constant quantities. Throws InvalidArgument naming the
  /// source, the field and the offending value for: non-positive mass, non-symmetric or
  /// non-positive-definite inertia, non-finite numbers, bad rotor count, zero axis, spin not +-1,
  /// bad speed limits or time constants, a thrust curve that is not increasing over the speed
  /// range, or a rank-deficient allocation matrix.
  explicit VehicleModel(VehicleSpec spec);

  const VehicleSpec& spec() const { return spec_; }
  const std::string& name() const { return spec_.name; }
  int num_rotors() const { return static_cast<int>(spec_.rotors.size()); }
  const RotorParams& rotor(int i) const { return spec_.rotors[static_cast<std::size_t>(i)]; }
  double mass_kg() const { return spec_.mass_kg; }
  const Mat3& inertia_kgm2() const { return spec_.inertia_kgm2; }
  const Mat3& inertia_inverse() const { return inertia_inv_; }
  const Mat3& body_drag_Ns_per_m() const { return spec_.body_drag_Ns_per_m; }
  double ground_effect_min_height_m() const { return spec_.ground_effect_min_height_m; }

  /// Thesis Eq. 2.30 generalised: column i = [axis_i.z; r_i x axis_i + eps_i axis_i / K_tau,i].
  const AllocationMatrix& allocation_matrix() const { return allocation_; }
  /// Moore-Penrose pseudo-inverse of allocation_matrix() (N x 4).
  const AllocationInverse& allocation_pseudo_inverse() const { return allocation_pinv_; }
  /// Full 6 x N rotor wrench per unit thrust [axis_i; r_i x axis_i + eps_i axis_i / K_tau,i].
  const WrenchMatrix& wrench_matrix() const { return wrench_; }
  /// Pseudo-inverse of wrench_matrix() (N x 6): least-squares thrusts for a full body wrench.
  const WrenchInverse& wrench_pseudo_inverse() const { return wrench_pinv_; }
  /// Rank of wrench_matrix(): 4 for coplanar rotors, up to 6 for tilted layouts.
  int wrench_rank() const { return wrench_rank_; }
  /// Geometric constants of rotor i (see RotorGeometry).
  const RotorGeometry& rotor_geometry(int i) const {
    return geometry_[static_cast<std::size_t>(i)];
  }

  /// Per-rotor thrust (N) holding the vehicle still in the air, from the wrench pseudo-inverse
  /// applied to [0, 0, m g, 0, 0, 0] (g = 9.81 m/s^2 unless given).
  RotorVector hover_thrusts_N(double gravity_m_s2 = 9.81) const;
  /// Per-rotor speeds (rad/s) giving hover_thrusts_N() through the full thrust polynomial.
  RotorVector hover_speeds_rad_s(double gravity_m_s2 = 9.81) const;

  /// Rotor thrusts for generalized forces u = [T, tau_x, tau_y, tau_z] (A^+ u), N.
  RotorVector thrusts_for(const GeneralizedForce& u) const;

 private:
  VehicleSpec spec_;
  Mat3 inertia_inv_;
  AllocationMatrix allocation_;
  AllocationInverse allocation_pinv_;
  WrenchMatrix wrench_;
  WrenchInverse wrench_pinv_;
  int wrench_rank_ = 0;
  std::array<RotorGeometry, kMaxRotors> geometry_{};
};

}  // namespace dronetwin
