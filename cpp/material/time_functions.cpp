#include "material/time_functions.h"

#include "material/parameters.h"

#include <cmath>
#include <string>

namespace muscle
{

TwitchTrain::TwitchTrain(const ParameterSet& p)
    : _N_a(p["N_a"]), _t0(p["t0"])
{
  for (int i = 0; i < 3; ++i)
  {
    const std::string k = std::to_string(i + 1);
    _F[i] = p["F_" + k];
    _T[i] = p["T_" + k];
    _I[i] = p["I_" + k];
    _rho[i] = p["rho_" + k];
  }
}

namespace
{
double gain(double T, double I)
{
  const double r = T / I;
  return (1 - std::exp(-2 * r * r * r)) / r;
}
} // namespace

double TwitchTrain::value(double t) const
{
  double total = 0;
  for (int i = 0; i < 3; ++i)
  {
    double sum = 0;
    for (int j = 0; _t0 + j * _I[i] < t; ++j)
    {
      const double x = (t - (_t0 + j * _I[i])) / _T[i];
      sum += _F[i] * x * std::exp(1 - x);
    }
    total += _rho[i] * gain(_T[i], _I[i]) * sum;
  }
  return _N_a * total;
}

double TwitchTrain::tetanic_level() const
{
  double total = 0;
  for (int i = 0; i < 3; ++i)
    total += _rho[i] * gain(_T[i], _I[i]) * std::exp(1.0) * _F[i] * _T[i] / _I[i];
  return _N_a * total;
}

double tanh_activation(double c, double t0, double t)
{
  return t > t0 ? std::tanh(c * (t - t0)) : 0.0;
}

double time_factor(const ParameterSet& p, double t)
{
  if (!p.model().active())
    return 0.0;
  if (uses_twitch_train(p.model()))
  {
    const TwitchTrain train(p);
    const double level = train.tetanic_level();
    return level > 0 ? train.value(t) / level : 0.0;
  }
  return tanh_activation(p["c"], p["t0"], t);
}

} // namespace muscle
