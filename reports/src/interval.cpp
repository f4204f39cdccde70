#include <rtsim/reports/interval.h>

#include <cmath>
#include <iterator>
#include <numeric>

namespace rtsim {

double t_quantile_975(size_t df) {
  static const double kTable[] = {0,      12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365,
                                  2.306,  2.262,  2.228, 2.201, 2.179, 2.160, 2.145, 2.131,
                                  2.120,  2.110,  2.101, 2.093, 2.086, 2.080, 2.074, 2.069,
                                  2.064,  2.060,  2.056, 2.052, 2.048, 2.045, 2.042};
  if (df == 0) return NAN;
  if (df < std::size(kTable)) return kTable[df];
  // Beyond the table t is close to linear in 1/df (within 0.001 here).
  const double inv = 1.0 / double(df);
  if (df <= 60) return 2.000 + (2.042 - 2.000) * (inv - 1.0 / 60) / (1.0 / 30 - 1.0 / 60);
  return 1.960 + (2.000 - 1.960) * 60.0 * inv;
}

Interval interval_of(const std::vector<double>& x) {
  Interval r;
  std::vector<double> v;
  for (double d : x)
    if (std::isfinite(d)) v.push_back(d);
  r.n = v.size();
  if (v.empty()) return r;
  r.mean = std::accumulate(v.begin(), v.end(), 0.0) / double(v.size());
  if (v.size() < 2) return r;
  double ss = 0;
  for (double d : v) ss += (d - r.mean) * (d - r.mean);
  const double half = t_quantile_975(v.size() - 1) * std::sqrt(ss / double(v.size() - 1) / double(v.size()));
  r.lo = r.mean - half;
  r.hi = r.mean + half;
  return r;
}

}  // namespace rtsim
