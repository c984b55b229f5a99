#pragma once
// Numerics of the streamed fit (fit.cpp), free of any physics:
//
//   MagnitudeHistogram   the median of |r| over millions of residuals without storing them;
//   for_each_chunk       chunks of a pass on several threads, each chunk's sums kept apart so the
//                        caller adds them up in chunk order (bitwise the same on any number of
//                        threads);
//   NormalEquations      sum of w J^T J, w J^T r and the loss, built from rows of residuals and
//                        their Jacobians in blocks (one rank update per block);
//   square_root_information
//                        a residual vector r~ and Jacobian J~ with J~^T J~ = H, J~^T r~ = g and
//                        |r~|^2 = loss: what a whole stream of residuals looks like to a
//                        least-squares solver at one point (Ceres sees one small block instead of
//                        millions of rows).

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace dronetwin::detail {

/// Counts of |r| in bins of 1/32 of an octave (2.2 % wide) from 2^-60 to 2^40; values outside
/// fall into the end bins. Counts are integers, so histograms merge in any order to the same
/// result. The bins are allocated on the first add (an unused histogram costs nothing).
class MagnitudeHistogram {
 public:
  static constexpr int kMinExponent = -60, kMaxExponent = 40, kPerOctave = 32;
  static constexpr int kBins = (kMaxExponent - kMinExponent) * kPerOctave;

  void add(double magnitude) {
    if (bins_.empty()) bins_.assign(static_cast<std::size_t>(kBins), 0);
    ++bins_[static_cast<std::size_t>(bin_of(magnitude))];
    ++count_;
  }
  void merge(const MagnitudeHistogram& other) {
    if (other.count_ == 0) return;
    if (bins_.empty()) bins_.assign(static_cast<std::size_t>(kBins), 0);
    for (std::size_t i = 0; i < bins_.size(); ++i) bins_[i] += other.bins_[i];
    count_ += other.count_;
  }
  std::uint64_t count() const { return count_; }
  /// The median magnitude, to within half a bin (1.1 %): the geometric middle of its bin; 0 when
  /// empty.
  double median() const {
    if (count_ == 0) return 0.0;
    const std::uint64_t half = (count_ + 1) / 2;
    std::uint64_t seen = 0;
    for (int b = 0; b < kBins; ++b) {
      seen += bins_[static_cast<std::size_t>(b)];
      if (seen >= half) {
        return std::exp2(kMinExponent + (static_cast<double>(b) + 0.5) / kPerOctave);
      }
    }
    return std::exp2(kMaxExponent);
  }

 private:
  static int bin_of(double magnitude) {
    if (!(magnitude > 0.0)) return 0;  // zero and NaN count in the lowest bin
    const double octave = std::log2(magnitude);
    const double b = std::floor((octave - kMinExponent) * kPerOctave);
    return static_cast<int>(std::clamp(b, 0.0, static_cast<double>(kBins - 1)));
  }
  std::vector<std::uint64_t> bins_;
  std::uint64_t count_ = 0;
};

/// Calls f(chunk, worker) for chunk = 0 .. num_chunks-1 on up to num_threads threads (worker in
/// [0, num_threads)); which thread takes which chunk varies, so f must write its results per
/// chunk (or per worker, for order-free integer counts). The first exception is rethrown.
template <class F>
void for_each_chunk(std::size_t num_chunks, int num_threads, F&& f) {
  const auto workers = static_cast<std::size_t>(std::max(
      1, std::min(num_threads, static_cast<int>(std::min<std::size_t>(num_chunks, 1024)))));
  if (workers <= 1) {
    for (std::size_t c = 0; c < num_chunks; ++c) f(c, 0);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  const auto work = [&](int worker) {
    try {
      for (std::size_t c = next++; c < num_chunks; c = next++) f(c, worker);
    } catch (...) {
      const std::lock_guard<std::mutex> lock(failure_mutex);
      if (!failure) failure = std::current_exception();
      next = num_chunks;
    }
  };
  std::vector<std::thread> threads;
  for (std::size_t w = 1; w < workers; ++w) threads.emplace_back(work, static_cast<int>(w));
  work(0);
  for (std::thread& t : threads) t.join();
  if (failure) std::rethrow_exception(failure);
}

/// H = sum J^T J, g = sum J^T r over rows given one at a time (already weighted), gathered in
/// blocks of kBlockRows so the sums are one symmetric rank update per block. The block boundaries
/// depend only on the order rows arrive in, so the sums are reproducible bit for bit.
class NormalEquations {
 public:
  static constexpr int kBlockRows = 256;

  explicit NormalEquations(int num_parameters)
      : information_(Eigen::MatrixXd::Zero(num_parameters, num_parameters)),
        gradient_(Eigen::VectorXd::Zero(num_parameters)),
        rows_(kBlockRows, num_parameters),
        residuals_(kBlockRows) {}

  /// Adds one row: d residual / d parameters (num_parameters numbers) and the residual.
  template <class Derivatives>
  void add(const Derivatives& jacobian_row, double residual) {
    for (Eigen::Index j = 0; j < rows_.cols(); ++j) rows_(used_, j) = jacobian_row[j];
    residuals_[used_] = residual;
    if (++used_ == kBlockRows) flush();
  }
  /// The sums; upper and lower triangle of the information matrix filled.
  void finish(Eigen::MatrixXd& information, Eigen::VectorXd& gradient) {
    flush();
    information = information_.selfadjointView<Eigen::Lower>();
    gradient = gradient_;
  }

 private:
  void flush() {
    if (used_ == 0) return;
    const auto block = rows_.topRows(used_);
    information_.selfadjointView<Eigen::Lower>().rankUpdate(block.transpose());
    gradient_.noalias() += block.transpose() * residuals_.head(used_);
    used_ = 0;
  }
  Eigen::MatrixXd information_;
  Eigen::VectorXd gradient_;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rows_;
  Eigen::VectorXd residuals_;
  Eigen::Index used_ = 0;
};

/// Writes r~ (n + 1 numbers) and J~ ((n + 1) x n, row-major) with J~^T J~ = H, J~^T r~ = g and
/// |r~|^2 = loss for the n x n symmetric positive semi-definite H: with H = V diag(l) V^T, row i
/// of J~ is sqrt(l_i) v_i^T and r~_i = v_i^T g / sqrt(l_i) (0 in H's null space, where g has
/// no component either); the last residual carries the rest of the loss, which no parameter
/// change can remove (loss >= g^T H^+ g for least squares and for the IRLS form of a robust
/// loss, so its square root is real up to round-off).
inline void square_root_information(const Eigen::MatrixXd& information,
                                    const Eigen::VectorXd& gradient, double loss, double* residuals,
                                    double* jacobian) {
  const Eigen::Index n = information.rows();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(information);
  const Eigen::VectorXd& l = es.eigenvalues();
  const Eigen::MatrixXd& v = es.eigenvectors();
  const double tiny = std::max(l.maxCoeff(), 0.0) * 1e-15;
  double explained = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const bool in_range = l[i] > tiny && l[i] > 0.0;
    const double root = in_range ? std::sqrt(l[i]) : 0.0;
    residuals[i] = in_range ? v.col(i).dot(gradient) / root : 0.0;
    explained += residuals[i] * residuals[i];
    if (jacobian != nullptr) {
      for (Eigen::Index j = 0; j < n; ++j) jacobian[i * n + j] = root * v(j, i);
    }
  }
  residuals[n] = std::sqrt(std::max(0.0, loss - explained));
  if (jacobian != nullptr) {
    for (Eigen::Index j = 0; j < n; ++j) jacobian[n * n + j] = 0.0;
  }
}

}  // namespace dronetwin::detail
