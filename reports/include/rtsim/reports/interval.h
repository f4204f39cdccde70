#pragma once
// The mean of a few replicates and its 95% Student-t interval: the claim map's
// verdicts and Table 1's seed spread read the same one.
#include <cmath>
#include <cstddef>
#include <vector>

namespace rtsim {

struct Interval {
  size_t n = 0;
  double mean = NAN, lo = NAN, hi = NAN;  // lo, hi: NaN with fewer than 2 finite values
  double half_width() const { return (hi - lo) / 2; }
};

// Over the finite values of x.
Interval interval_of(const std::vector<double>& x);

// Two-sided 95% quantile of Student's t with `df` degrees of freedom (df >= 1).
double t_quantile_975(size_t df);

}  // namespace rtsim
