#pragma once

#include <array>

namespace muscle
{
class ParameterSet;

/// Superposition of motor-unit twitches, P_opt f_t = N_a sum_i rho_i F_t^i
/// (paper eq. Poptft, formula in ERRATA.md after Ehret et al. 2011).
///
/// Motor-unit type i fires at t_j = t0 + j I_i; each stimulus adds the twitch
/// F_i x exp(1 - x), x = (t - t_j)/T_i, scaled by the gain
/// G_i = (1 - exp(-2 (T_i/I_i)^3)) / (T_i/I_i).
class TwitchTrain
{
public:
  explicit TwitchTrain(const ParameterSet& parameters);

  /// P_opt f_t at time t [kPa]; zero before t0.
  double value(double t) const;

  /// Time average of the train in the fused tetanic state [kPa]:
  /// N_a sum_i rho_i G_i e F_i T_i / I_i (the integral of one twitch is e F_i T_i).
  double tetanic_level() const;

private:
  double _N_a, _t0;
  std::array<double, 3> _F, _T, _I, _rho;
};

/// max(0, tanh(c (t - t0))): the BLE / COMBI activation in time (paper eq.
/// ft_blemker), held at zero before the start time.
double tanh_activation(double c, double t0, double t);

/// The dimensionless time factor the forms and kernels multiply P_opt (or
/// alpha_a for BLE) with: tanh_activation for BLE and COMBI, the twitch train
/// divided by its tetanic level for WKM and GIANT.  It is 1 in the tetanic state
/// used by the active load cases.
double time_factor(const ParameterSet& parameters, double t);

} // namespace muscle
