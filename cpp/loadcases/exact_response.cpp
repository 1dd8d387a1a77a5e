#include "common/errors.h"
#include "loadcases/load_case.h"

#include <boost/math/tools/roots.hpp>
#include <cmath>
#include <limits>

namespace muscle
{

const std::vector<LoadCase>& all_load_cases()
{
  static const std::vector<LoadCase> cases
      = {LoadCase::UTCAF, LoadCase::UTCTF, LoadCase::SAF,
         LoadCase::PSAF,  LoadCase::PSTF,  LoadCase::PSTIF};
  return cases;
}

std::string to_string(LoadCase c)
{
  switch (c)
  {
  case LoadCase::UTCAF:
    return "UTCAF";
  case LoadCase::UTCTF:
    return "UTCTF";
  case LoadCase::SAF:
    return "SAF";
  case LoadCase::PSAF:
    return "PSAF";
  case LoadCase::PSTF:
    return "PSTF";
  case LoadCase::PSTIF:
    return "PSTIF";
  }
  return "?";
}

LoadCase parse_load_case(const std::string& name)
{
  std::vector<std::string> names;
  for (LoadCase c : all_load_cases())
  {
    if (name == to_string(c))
      return c;
    names.push_back(to_string(c));
  }
  throw InputError("unknown load case '" + name + "'" + did_you_mean(name, names)
                   + "; allowed: " + join(names));
}

std::string to_string(MuscleState s)
{
  return s == MuscleState::active ? "active" : "passive";
}

MuscleState parse_state(const std::string& name)
{
  if (name == "active")
    return MuscleState::active;
  if (name == "passive")
    return MuscleState::passive;
  throw InputError("unknown muscle state '" + name
                   + "'; allowed: active, passive");
}

ReportedComponent reported_component(LoadCase c)
{
  switch (c)
  {
  case LoadCase::UTCAF:
  case LoadCase::PSAF:
    return {2, 2};
  case LoadCase::SAF:
    return {1, 2}; // P_23, ERRATA item 9
  default:
    return {0, 0};
  }
}

Matrix3 deformation_gradient(LoadCase c, double s, double lateral)
{
  auto diag = [](double a, double b, double d) -> Matrix3
  { return {a, 0, 0, 0, b, 0, 0, 0, d}; };
  switch (c)
  {
  case LoadCase::UTCAF:
    return diag(1 / std::sqrt(s), 1 / std::sqrt(s), s);
  case LoadCase::UTCTF:
    return diag(s, lateral, 1 / (s * lateral));
  case LoadCase::SAF:
    return {1, 0, 0, 0, 1, 0, 0, s, 1}; // x3 = X3 + s X2
  case LoadCase::PSAF:
    return diag(1 / s, 1, s);
  case LoadCase::PSTF:
    return diag(s, 1, 1 / s);
  case LoadCase::PSTIF:
    return diag(s, 1 / s, 1);
  }
  return {};
}

namespace
{
/// Free direction (traction-free face normal) whose diagonal condition gives p.
int free_direction(LoadCase c)
{
  switch (c)
  {
  case LoadCase::UTCAF:
  case LoadCase::SAF:
  case LoadCase::PSAF:
    return 0;
  case LoadCase::PSTF:
    return 2;
  case LoadCase::PSTIF:
    return 1;
  default:
    return 1;
  }
}
} // namespace

ExactResponse exact_response(const MaterialPointModel& model, LoadCase c,
                             double s)
{
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const ReportedComponent out = reported_component(c);

  if (c == LoadCase::UTCTF)
  {
    // F = diag(s, a, 1/(s a)); P22 = 0 gives p = a P22_model; P33 = 0 fixes a.
    auto residual = [&](double a)
    {
      const Matrix3 P = model.stress(point_at(deformation_gradient(c, s, a)));
      return P[8] - s * a * a * P[4];
    };
    const double guess = 1 / std::sqrt(s);
    double lo = guess, hi = guess;
    double r_lo = residual(lo), r_hi = r_lo;
    for (int i = 0; i < 60 and r_lo * r_hi > 0; ++i)
    {
      lo /= 1.05;
      hi *= 1.05;
      r_lo = residual(lo);
      r_hi = residual(hi);
    }
    if (r_lo * r_hi > 0)
      throw SolveError("UTCTF: no lateral stretch balances P_33 at stretch "
                       + std::to_string(s));
    double a = r_lo == 0 ? lo : hi; // an exact root at the guess (e.g. s = 1)
    if (r_lo != 0 and r_hi != 0)
    {
      std::uintmax_t iterations = 100;
      const auto [a0, a1] = boost::math::tools::toms748_solve(
          residual, lo, hi, r_lo, r_hi,
          boost::math::tools::eps_tolerance<double>(50), iterations);
      a = 0.5 * (a0 + a1);
    }
    const Matrix3 P = model.stress(point_at(deformation_gradient(c, s, a)));
    const double p = a * P[4];
    return {P[0] - p / s, p, a};
  }

  const Matrix3 F = deformation_gradient(c, s, nan);
  const Matrix3 P = model.stress(point_at(F));
  const int k = free_direction(c);
  // F is diagonal in its free direction: (F^-T)_kk = 1/F_kk
  const double p = P[4 * k] * F[4 * k];
  double reported = P[3 * out.i + out.j];
  if (c == LoadCase::SAF)
    reported += p * s; // (F^-T)_23 = -s
  else
    reported -= p / F[4 * out.i];
  return {reported, p, nan};
}

} // namespace muscle
