#include "dronetwin/sensors/bias_process.hpp"

namespace dronetwin {

double gauss_markov_allan_peak_ratio() {
  // The ratio is unimodal in x = tau / T (it rises from 0 like 2x / 3 and falls like 2 / x):
  // golden-section search on log x over [0.1, 100].
  static const double peak = [] {
    const double g = 0.5 * (std::sqrt(5.0) - 1.0);
    double a = std::log(0.1), b = std::log(100.0);
    for (int i = 0; i < 200; ++i) {
      const double c = b - g * (b - a), d = a + g * (b - a);
      if (gauss_markov_allan_variance_ratio(std::exp(c)) >
          gauss_markov_allan_variance_ratio(std::exp(d)))
        b = d;
      else
        a = c;
    }
    return std::sqrt(gauss_markov_allan_variance_ratio(std::exp(0.5 * (a + b))));
  }();
  return peak;
}

double gauss_markov_sigma_for_bias_instability(double bias_instability) {
  static const double factor =
      std::sqrt(2.0 * std::log(2.0) / M_PI) / gauss_markov_allan_peak_ratio();
  return bias_instability * factor;
}

}  // namespace dronetwin
