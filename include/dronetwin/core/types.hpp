#pragma once
// Fixed-size numeric types shared by every layer of dronetwin.
//
// The rigid-body state follows thesis Eq. 2.20:
//   x = [p_W (3), v_W (3), q_WB (w, x, y, z) (4), w_B (3)]
// p_W, v_W: position and velocity of the centre of mass in the world frame (z up), m and m/s.
// q_WB: unit quaternion rotating body-frame vectors into the world frame (v_W = R(q) v_B).
// w_B: body angular velocity expressed in the body frame, rad/s.
//
// Rotor-indexed vectors have a runtime length (the model's rotor count) but a compile-time
// maximum, so they never touch the heap.

#include <Eigen/Core>
#include <Eigen/Geometry>  // cross products

/// Inlines every call inside a function, recursively (GCC's flatten): the SIMD pack step, whose
/// pack operators and Eigen loops GCC otherwise calls out of line. Optimised builds only: with
/// sanitizers and -g (the asan-ubsan and tsan presets) GCC 12 took over 10 minutes to compile the
/// flattened step, which there only needs to be correct, not fast.
#if defined(__GNUC__) && !defined(__clang__) && defined(NDEBUG)
#define DRONETWIN_FLATTEN [[gnu::flatten]]
#else
#define DRONETWIN_FLATTEN
#endif

/// Forces inlining of small hot functions (the RK4 stages call them four times per step).
#if defined(__GNUC__) || defined(__clang__)
#define DRONETWIN_HOT_INLINE __attribute__((always_inline)) inline
#else
#define DRONETWIN_HOT_INLINE inline
#endif

namespace dronetwin {

/// Largest rotor count a vehicle model may have. Rotor arrays are stack-allocated up to this.
inline constexpr int kMaxRotors = 8;

/// Length of the rigid-body state vector (thesis Eq. 2.20).
inline constexpr int kStateSize = 13;

template <class T>
using Vector3 = Eigen::Matrix<T, 3, 1>;
template <class T>
using Matrix3 = Eigen::Matrix<T, 3, 3>;
template <class T>
using Vector4 = Eigen::Matrix<T, 4, 1>;

using Vec3 = Vector3<double>;
using Mat3 = Matrix3<double>;
using Vec4 = Vector4<double>;

/// [p_W, v_W, q_WB (wxyz), w_B], thesis Eq. 2.20.
using StateVector = Eigen::Matrix<double, kStateSize, 1>;

/// One value per rotor (speeds in rad/s, thrusts in N, ...). Size = model rotor count.
using RotorVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxRotors, 1>;

/// Generalized forces [T (N), tau_x, tau_y, tau_z (N m)] in the body frame (thesis Eq. 2.30).
using GeneralizedForce = Vec4;

/// Offsets of each block inside StateVector.
namespace state_index {
inline constexpr int kPosition = 0;
inline constexpr int kVelocity = 3;
inline constexpr int kQuaternion = 6;  // w, x, y, z
inline constexpr int kAngularVelocity = 10;
}  // namespace state_index

}  // namespace dronetwin
