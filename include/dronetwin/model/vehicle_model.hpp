#pragma once
// The description of one multirotor airframe, in two layers:
//
// - VehicleModelTpl<S>: the physical parameters the force kernel reads (mass, inertia, frame drag,
//   rotors) in a scalar S, plus J^-1 derived from them. S is double for the simulator, float for
//   the single-precision batch, ceres::Jet when a fit differentiates with respect to the
//   parameters, and a SIMD pack when each lane of a batch flies its own randomised vehicle
//   (core/simd.hpp). Like Pinocchio's ModelTpl, cast<S2>() converts a double model.
// - VehicleModel: the validated double model of a file. It is a VehicleModelTpl<double> and adds
//   what a file states besides numbers (name, source) and constants derived once for control:
//   the allocation matrix (thesis Eq. 2.30 generalised to N rotors with arbitrary positions and
//   axes), its pseudo-inverse, the rotor wrench matrix, the hover rotor speeds.
//
//   auto model = std::make_shared<const VehicleModel>(load_vehicle_model("models/qdrone2.yaml"));
//   std::cout << model->allocation_matrix() << "\n";      // 4 x N, Eq. 2.30
//   RotorVector w = model->hover_speeds_rad_s();          // exact thrust-polynomial inverse
//   VehicleModelTpl<float> f = model->cast<float>();      // the same airframe in float
//   auto heavier = model->edited([](auto& p) { p.mass_kg *= 1.1; });   // a VehicleModelTpl<double>
//
// Trap: a VehicleModel cannot change after construction. edited() returns the parameters-only
// VehicleModelTpl (no allocation or hover trim, which would be stale): enough for the force
// kernel. For a new validated model, copy the VehicleSpec, edit it, and build a VehicleModel.

#include <array>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dronetwin/core/scalar.hpp"
#include "dronetwin/core/types.hpp"
#include "dronetwin/model/rotor_params.hpp"
#include "dronetwin/world/collision_shape.hpp"

namespace dronetwin {

/// The physical parameters of an airframe in scalar S: what the force kernel reads, and what a
/// fit or a per-lane randomisation changes. Plain data.
template <class S>
struct VehicleParametersTpl {
  using Value = scalar::value_type_t<S>;
  int num_rotors = 0;
  std::array<RotorParamsTpl<S>, kMaxRotors> rotors{};
  S mass_kg = S(0);
  /// Full 3x3 inertia about the centre of mass, body frame, kg m^2 (thesis Table 2.1 / Eq. 2.39).
  Matrix3<S> inertia_kgm2 = Matrix3<S>::Zero();
  /// Body (frame) aerodynamic drag matrix A: F_A = -A v_air (thesis Eq. 2.32), N s/m, applied in
  /// the body frame (see docs/conventions.md).
  Matrix3<S> body_drag_Ns_per_m = Matrix3<S>::Zero();
  /// Floor for the rotor height h in the ground-effect term C_G T / h^2, m.
  Value ground_effect_min_height_m = Value(0.023);
};

template <class S>
class VehicleModelTpl {
 public:
  using Scalar = S;
  using Value = scalar::value_type_t<S>;
  using Parameters = VehicleParametersTpl<S>;

  /// Derives J^-1 from the parameters. No validation: a VehicleModel validates its file; a cast or
  /// an edited copy inherits that (the caller of edited() keeps the parameters physical).
  explicit VehicleModelTpl(Parameters parameters) : p_(std::move(parameters)) {
    inertia_inverse_ = p_.inertia_kgm2.inverse();
    inertia_is_diagonal_ = true;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        if (r != c &&
            !(scalar::is_zero(p_.inertia_kgm2(r, c)) && scalar::is_zero(inertia_inverse_(r, c))))
          inertia_is_diagonal_ = false;
  }

  const Parameters& parameters() const { return p_; }
  int num_rotors() const { return p_.num_rotors; }
  const RotorParamsTpl<S>& rotor(int i) const { return p_.rotors[static_cast<std::size_t>(i)]; }
  const S& mass_kg() const { return p_.mass_kg; }
  const Matrix3<S>& inertia_kgm2() const { return p_.inertia_kgm2; }
  const Matrix3<S>& inertia_inverse() const { return inertia_inverse_; }
  /// True when J and J^-1 have exactly zero off-diagonal terms (principal axes = body axes): the
  /// rigid-body equations then skip the products by zero.
  bool inertia_is_diagonal() const { return inertia_is_diagonal_; }
  const Matrix3<S>& body_drag_Ns_per_m() const { return p_.body_drag_Ns_per_m; }
  Value ground_effect_min_height_m() const { return p_.ground_effect_min_height_m; }

  /// The same airframe with parameters of scalar S2 (from a double model only).
  template <class S2>
  VehicleModelTpl<S2> cast() const requires std::is_arithmetic_v<S> {
    VehicleParametersTpl<S2> q;
    q.num_rotors = p_.num_rotors;
    for (std::size_t i = 0; i < kMaxRotors; ++i) q.rotors[i] = p_.rotors[i].template cast<S2>();
    q.mass_kg = scalar::from_value<S2>(p_.mass_kg);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) {
        q.inertia_kgm2(r, c) = scalar::from_value<S2>(p_.inertia_kgm2(r, c));
        q.body_drag_Ns_per_m(r, c) = scalar::from_value<S2>(p_.body_drag_Ns_per_m(r, c));
      }
    }
    q.ground_effect_min_height_m =
        static_cast<typename VehicleParametersTpl<S2>::Value>(p_.ground_effect_min_height_m);
    return VehicleModelTpl<S2>(std::move(q));
  }

  /// A copy whose parameters `edit(Parameters&)` has changed, with J^-1 derived again.
  template <class Edit>
  VehicleModelTpl edited(Edit&& edit) const {
    Parameters q = p_;
    edit(q);
    return VehicleModelTpl(std::move(q));
  }

 private:
  Parameters p_;
  Matrix3<S> inertia_inverse_;
  bool inertia_is_diagonal_ = true;
};

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
  /// `collision:` of the file: the shape that touches the scene (world/collision.hpp); empty:
  /// VehicleModel::collision_shape() puts a sphere over the rotors.
  std::optional<CollisionShape> collision;
};

/// 4 x N allocation matrix: [T; tau_x; tau_y; tau_z] = A * rotor thrusts.
using AllocationMatrix = Eigen::Matrix<double, 4, Eigen::Dynamic, Eigen::ColMajor, 4, kMaxRotors>;
/// N x 4 right pseudo-inverse of the allocation matrix.
using AllocationInverse = Eigen::Matrix<double, Eigen::Dynamic, 4, Eigen::ColMajor, kMaxRotors, 4>;
/// 6 x N rotor wrench matrix: [F_B; M_B] per unit thrust of each rotor.
using WrenchMatrix = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::ColMajor, 6, kMaxRotors>;
using WrenchInverse = Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::ColMajor, kMaxRotors, 6>;

class VehicleModel : public VehicleModelTpl<double> {
 public:
  /// Validates `spec` and derives the constant quantities. Throws InvalidArgument naming the
  /// source, the field and the offending value for: non-positive mass, non-symmetric or
  /// non-positive-definite inertia, non-finite numbers, bad rotor count, zero axis, spin not +-1,
  /// bad speed limits or time constants, a thrust curve that is not increasing over the speed
  /// range, or a rank-deficient allocation matrix.
  explicit VehicleModel(VehicleSpec spec);

  const VehicleSpec& spec() const { return spec_; }
  const std::string& name() const { return spec_.name; }

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

  /// Per-rotor thrust (N) holding the vehicle still in the air, from the wrench pseudo-inverse
  /// applied to [0, 0, m g, 0, 0, 0] (g = 9.81 m/s^2 unless given).
  RotorVector hover_thrusts_N(double gravity_m_s2 = 9.81) const;
  /// Per-rotor speeds (rad/s) giving hover_thrusts_N() through the full thrust polynomial,
  /// clamped to the speed limits (check can_hover() first: a clamped speed does not hover).
  RotorVector hover_speeds_rad_s(double gravity_m_s2 = 9.81) const;
  /// True when every rotor can give its hover thrust within its speed limits at `gravity_m_s2`:
  /// T(min speed) <= hover thrust <= T(max speed).
  bool can_hover(double gravity_m_s2 = 9.81) const;

  /// The spec's collision shape, or else a sphere about the body origin of radius: the largest
  /// rotor-hub distance plus 0.1 m (a propeller's radius on a QDrone2-size vehicle).
  const CollisionShape& collision_shape() const { return collision_; }

  /// Rotor thrusts for generalized forces u = [T, tau_x, tau_y, tau_z] (A^+ u), N.
  RotorVector thrusts_for(const GeneralizedForce& u) const;

 private:
  /// The validated spec (axes normalised) and the parameters built from it.
  using Validated = std::pair<VehicleSpec, VehicleParametersTpl<double>>;
  static Validated validate(VehicleSpec spec);
  explicit VehicleModel(Validated validated);

  VehicleSpec spec_;
  AllocationMatrix allocation_;
  AllocationInverse allocation_pinv_;
  WrenchMatrix wrench_;
  WrenchInverse wrench_pinv_;
  int wrench_rank_ = 0;
  CollisionShape collision_;
};

}  // namespace dronetwin
