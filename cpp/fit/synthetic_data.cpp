// Data from known parameters, for testing the fit and the identifiability
// analysis against a known answer.
#include "fit/fit.h"

#include <common/errors.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace muscle::fit
{

std::vector<DataPoint> synthesize(const ParameterSet& p, const std::vector<CurveKey>& curves,
                                  const std::vector<double>& stretches,
                                  const std::vector<double>& shears, Kinematics kinematics,
                                  double noise, unsigned seed)
{
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0, 1);
  std::vector<DataPoint> out;
  for (const CurveKey& k : curves)
  {
    const std::vector<double>& controls = k.load_case == LoadCase::SAF ? shears : stretches;
    std::vector<double> stress;
    if (kinematics == Kinematics::paper and k.load_case == LoadCase::UTCTF)
    {
      for (double s : controls)
      {
        const auto v = paper_response(p, k.load_case, k.state, s);
        if (!v)
          throw InputError("the paper's UTCTF kinematics have a closed form for the "
                           "passive state only");
        stress.push_back(*v);
      }
    }
    else
      stress = model_curve(p, k, controls);
    double peak = 0;
    for (double v : stress)
      peak = std::max(peak, std::abs(v));
    for (std::size_t i = 0; i < controls.size(); ++i)
      out.push_back({k.load_case, k.state, controls[i],
                     stress[i] + noise * peak * normal(rng), "", 0});
  }
  return out;
}

} // namespace muscle::fit
