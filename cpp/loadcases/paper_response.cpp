// The paper's closed-form load-case responses (appendix table
// tab:analytical_responses), written from the table, with ERRATA.md applied.
// Deliberately independent of the UFL forms: this is the reference the exact
// homogeneous responses are tested against.
#include "loadcases/load_case.h"

#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <boost/math/special_functions/lambert_w.hpp>
#include <boost/math/tools/roots.hpp>
#include <cmath>

namespace muscle
{
namespace
{
double sgn(double x) { return (x > 0) - (x < 0); }

// ---------------------------------------------------------------- BLE ------

double f_active(double x)
{
  if (x <= 0.6)
    return 9 * (x - 0.4) * (x - 0.4);
  if (x < 1.4)
    return 1 - 4 * (1 - x) * (1 - x);
  return 9 * (x - 1.6) * (x - 1.6);
}

double f_passive(double l, const ParameterSet& p)
{
  const double P1 = p["P1"], P2 = p["P2"], ls = p["lambda_star"];
  const double P3 = P1 * P2 * std::exp(P2 * (ls - 1));
  const double P4 = P1 * (std::exp(P2 * (ls - 1)) - 1) - ls * P3;
  if (l >= ls)
    return P3 * l + P4;
  if (l > 1)
    return P1 * (std::exp(P2 * (l - 1)) - 1);
  return 0;
}

/// Total Cauchy fibre stress (paper eq. sigmafibtot_blemker), f_t = 1 or 0.
double sigma_total(double l, const ParameterSet& p, double f_t)
{
  const double lo = p["lambda_opt"], smax = p["sigma_max"];
  return smax * l / lo * p["alpha_a"] * f_t * f_active(l / lo)
         + smax * l * f_passive(l, p);
}

std::optional<double> ble(const ParameterSet& p, LoadCase c, double f_t,
                          double l)
{
  const double G1 = p["G1"], G2 = p["G2"], mu = p["mu"];
  switch (c)
  {
  case LoadCase::UTCAF:
    return sigma_total(l, p, f_t) / l + mu * (l - 1 / (l * l));
  case LoadCase::UTCTF:
  {
    if (f_t != 0)
      return std::nullopt;
    // ERRATA 7: theta = 1/2 l^1/2 (l + l^-2), fibre stretch l^-1/2
    const double theta = 0.5 * std::sqrt(l) * (l + 1 / (l * l));
    return 3 / l * G2 * std::acosh(theta) * sgn(l * l * l - 1)
           - 0.5 / l * sigma_total(1 / std::sqrt(l), p, 0)
           + mu * l * (1 - 1 / (l * l * l));
  }
  case LoadCase::SAF:
    return f_t != 0 ? std::nullopt : std::optional(l * (2 * G1 + mu));
  case LoadCase::PSAF:
    if (f_t != 0)
      return std::nullopt;
    // ERRATA 6: 2 G2 ln(l)/l
    return 2 * G2 * std::log(l) / l + sigma_total(l, p, 0) / l
           + mu * l * (1 - std::pow(l, -4));
  case LoadCase::PSTF:
    if (f_t != 0)
      return std::nullopt;
    return 2 * G2 * std::acosh(0.5 * (1 / l + l)) / l * sgn(l * l - 1)
           - sigma_total(1 / l, p, 0) / l + mu * l * (1 - std::pow(l, -4));
  case LoadCase::PSTIF:
    if (f_t != 0)
      return std::nullopt;
    return 4 / l * G2 * std::acosh(0.5 * (1 / (l * l) + l * l))
               * sgn(std::pow(l, 4) - 1)
           + mu * l * (1 - std::pow(l, -4));
  }
  return std::nullopt;
}

// ------------------------------------------------------ WKM / GIANT / COMBI --

struct Ehret
{
  double alpha, beta, gamma, w0, lmin, lopt, P_opt;
  explicit Ehret(const ParameterSet& p)
      : alpha(p["alpha"]), beta(p["beta"]), gamma(p["gamma"]), w0(p["omega_0"]),
        lmin(p["lambda_min"]), lopt(p["lambda_opt"]), P_opt(p["P_opt"])
  {
  }
  double eI(double I) const { return std::exp(alpha * (I - 1)); }
  double eJ(double J) const { return std::exp(beta * (J - 1)); }
};

/// f_xi exactly as printed in paper eq. fxi
double f_xi(double l, const Ehret& e)
{
  if (l <= e.lmin)
    return 0;
  return (l - e.lmin) / (e.lopt - e.lmin)
         * std::exp((2 * e.lmin - l - e.lopt) * (l - e.lopt)
                    / (2 * (e.lmin - e.lopt) * (e.lmin - e.lopt)));
}

/// int_{lambda_min}^{l} f_xi by adaptive Gauss-Kronrod quadrature
double f_xi_integral(double l, const Ehret& e)
{
  if (l <= e.lmin)
    return 0;
  return boost::math::quadrature::gauss_kronrod<double, 61>::integrate(
      [&](double s) { return f_xi(s, e); }, e.lmin, l, 15, 1e-14);
}

/// Passive first generalized invariant for uniaxial tension and its
/// derivative (ERRATA item 1).
double Ip(double l, double w0) { return l * l * (2.0 / 3 * w0 * (1 / (l * l * l) - 1) + 1); }
double dIp(double l, double w0) { return 2 * l * (1 - w0 / 3 * (1 / (l * l * l) + 2)); }

double wkm_utcaf(double l, double omega, const Ehret& e)
{
  const double w0 = e.w0, l3 = 1 / (l * l * l);
  const double I = l * l * (2.0 / 3 * w0 * (l3 - 1) + 1 + omega);
  const double J = 1 / (l * l) * (2.0 / 3 * w0 * (l * l * l - 1) + 1);
  return -e.gamma / 6
         * ((w0 * (2 + l3) - 3 * (1 + omega)) * l * e.eI(I)
            - (w0 * (1 + 2 * l3) - 3 * l3) * e.eJ(J));
}

/// WKM omega_a, paper eq. wa with Boost's W_0
double wkm_omega_paper(double l, const Ehret& e)
{
  const double P_act = e.P_opt * f_xi(l, e);
  if (P_act == 0)
    return 0;
  const double I = Ip(l, e.w0), dI = dIp(l, e.w0);
  const double chi = P_act * 2 * e.alpha * l / e.gamma
                         * std::exp(e.alpha / 2 * (2 - 2 * I + l * dI))
                     + e.alpha / 2 * l * dI * std::exp(e.alpha / 2 * l * dI);
  return boost::math::lambert_w0(chi) / (e.alpha * l * l) - dI / (2 * l);
}

/// COMBI omega_a and its derivative (paper section modified_material)
std::pair<double, double> combi_omega_paper(double l, const Ehret& e)
{
  const double integral = f_xi_integral(l, e);
  const double k = 4 * e.alpha / e.gamma * std::exp(e.alpha * (1 - Ip(l, e.w0)))
                   * e.P_opt;
  const double phi = 1 + k * integral;
  const double dphi = k * (f_xi(l, e) - e.alpha * dIp(l, e.w0) * integral);
  const double a = e.alpha * l * l;
  return {std::log(phi) / a, (dphi / phi - 2 / l * std::log(phi)) / a};
}

/// GIANT's generalized elastic invariants for uniaxial tension (appendix)
double Ie(double l, double w, double w0)
{
  const double eta = 1 - w;
  return 2 * w0 * eta / (3 * l) + (1 - 2 * w0 / 3) * l * l / (eta * eta);
}
double Je(double l, double w, double w0)
{
  const double eta = 1 - w;
  return 2 * w0 * l / (3 * eta) + (1 - 2 * w0 / 3) * eta * eta / (l * l);
}

/// GIANT omega_a from paper eq. waimplicit (bracketing solver on the equation
/// as printed, root with omega_a in [max(0, 1 - l), 1)).
double giant_omega_paper(double l, const Ehret& e)
{
  const double rhs_active = 4 / e.gamma * e.P_opt * f_xi_integral(l, e);
  if (rhs_active == 0)
    return 0;
  auto g = [&](double w)
  {
    return e.eI(Ie(l, w, e.w0)) / e.alpha + e.eJ(Je(l, w, e.w0)) / e.beta
           - e.eI(Ie(l, 0, e.w0)) / e.alpha - e.eJ(Je(l, 0, e.w0)) / e.beta
           - rhs_active;
  };
  double lo = std::max(0.0, 1 - l), hi = lo + 0.5 * (1 - lo);
  while (g(hi) < 0)
    hi = hi + 0.5 * (1 - hi);
  std::uintmax_t it = 200;
  const auto [a, b] = boost::math::tools::toms748_solve(
      g, lo, hi, boost::math::tools::eps_tolerance<double>(52), it);
  return 0.5 * (a + b);
}

double giant_utcaf(double l, const Ehret& e)
{
  // omega_a' by central differences, as the paper's 4C implementation does
  const double w = giant_omega_paper(l, e), h = 1e-6;
  const double dw = (giant_omega_paper(l + h, e) - giant_omega_paper(l - h, e)) / (2 * h);
  const double eta = 1 - w, w0 = e.w0, l3 = l * l * l, eta3 = eta * eta * eta;
  return -e.gamma / 6
         * ((w0 * (2 + eta3 / l3) - 3) * l / eta3 * e.eI(Ie(l, w, w0))
            - (w0 * (2 + l3 / eta3) - 3) / l3 * eta * e.eJ(Je(l, w, w0)))
         * (eta + dw * l);
}

std::optional<double> ehret(const ParameterSet& p, LoadCase c, double f_t,
                            double l)
{
  const Ehret e(p);
  const double w0 = e.w0, g6 = e.gamma / 6;
  if (f_t != 0)
  {
    if (c != LoadCase::UTCAF)
      return std::nullopt;
    const std::string law = p.model().name();
    if (law == "wkm")
      return wkm_utcaf(l, wkm_omega_paper(l, e), e);
    if (law == "combi")
    {
      const auto [w, dw] = combi_omega_paper(l, e);
      const double I = l * l * (2.0 / 3 * w0 * (1 / (l * l * l) - 1) + 1 + w);
      return wkm_utcaf(l, w, e) + e.gamma / 4 * l * l * e.eI(I) * dw;
    }
    return giant_utcaf(l, e);
  }
  const double l4 = std::pow(l, -4);
  switch (c)
  {
  case LoadCase::UTCAF:
    return wkm_utcaf(l, 0, e);
  case LoadCase::UTCTF:
  {
    const double I = 1 / l * (w0 / 3 * (l * l * l - 1) + 1);
    const double J = l * (w0 / 3 * (1 / (l * l * l) - 1) + 1);
    return g6 * w0 * (1 - 1 / (l * l * l)) * (l * e.eI(I) + e.eJ(J));
  }
  case LoadCase::SAF:
  {
    const double I = w0 / 3 * l * l + 1, J = (1 - 2 * w0 / 3) * l * l + 1;
    return g6 * l * (w0 * e.eI(I) - (2 * w0 - 3) * (l * l + 1) * e.eJ(J));
  }
  case LoadCase::PSAF:
  {
    const double I = l * l * (w0 / 3 * (l4 + 1 / (l * l) - 2) + 1);
    const double J = 1 / (l * l) * (w0 / 3 * (std::pow(l, 4) + l * l - 2) + 1);
    return -g6 * l
           * ((w0 * (2 + l4) - 3) * e.eI(I) - (w0 * (1 + 2 * l4) - 3 * l4) * e.eJ(J));
  }
  case LoadCase::PSTF:
  {
    const double I = 1 / (l * l) * (w0 / 3 * (std::pow(l, 4) + l * l - 2) + 1);
    const double J = l * l * (w0 / 3 * (l4 + 1 / (l * l) - 2) + 1);
    return g6 * l
           * ((w0 * (1 + 2 * l4) - 3 * l4) * e.eI(I) - (w0 * (2 + l4) - 3) * e.eJ(J));
  }
  case LoadCase::PSTIF:
  {
    // ERRATA 5: I = J = w0/3 (l^2 + l^-2 - 2) + 1
    const double I = w0 / 3 * (l * l + 1 / (l * l) - 2) + 1;
    return g6 * l * w0 * (1 - l4) * (e.eI(I) + e.eJ(I));
  }
  }
  return std::nullopt;
}

} // namespace

const std::vector<Model>& paper_models()
{
  static const std::vector<Model> models = models_for("paper");
  return models;
}

std::optional<double> paper_response(const ParameterSet& p, LoadCase c,
                                     MuscleState state, double s)
{
  const double f_t = state == MuscleState::active ? 1.0 : 0.0;
  // the formulas the paper prints, for its four models; other laws have none
  const std::string law = p.model().name();
  if (law == "ble")
    return ble(p, c, f_t, s);
  if (law == "wkm" or law == "giant" or law == "combi")
    return ehret(p, c, f_t, s);
  return std::nullopt;
}

} // namespace muscle
