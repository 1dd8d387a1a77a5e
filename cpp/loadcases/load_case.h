#pragma once

#include "material/material_point.h"

#include <optional>
#include <string>
#include <vector>

namespace muscle
{

/// The six load cases of the paper (Table defgrad_and_loading_sketches), fibres
/// along e3.
enum class LoadCase
{
  UTCAF, ///< uniaxial tension/compression along the fibre
  UTCTF, ///< uniaxial tension/compression across the fibre (load along e1)
  SAF,   ///< simple shear along the fibre
  PSAF,  ///< pure shear along the fibre (e2 held)
  PSTF,  ///< pure shear across the fibre (e2 held)
  PSTIF, ///< pure shear across isometrically held fibres (e3 held)
};

const std::vector<LoadCase>& all_load_cases();
std::string to_string(LoadCase c);
LoadCase parse_load_case(const std::string& name);

/// Active = the tetanic level (time factor 1), passive = time factor 0.
enum class MuscleState
{
  active,
  passive
};
std::string to_string(MuscleState s);
MuscleState parse_state(const std::string& name);

/// Which stress component a load case reports: P_ij = component i of the
/// traction on the face with reference normal e_j.
struct ReportedComponent
{
  int i, j;
};
ReportedComponent reported_component(LoadCase c);

/// Fully incompressible deformation gradient of a load case for the control
/// value `s` (stretch, or shear for SAF); for UTCTF `lateral` is the stretch
/// along e2 (the paper assumes s^-1/2, the exact response differs).
Matrix3 deformation_gradient(LoadCase c, double s, double lateral);

/// The homogeneous, fully incompressible response computed from the model's
/// stress: P = P_model(F) - p F^-T with p from the traction-free direction
/// (for UTCTF also the lateral stretch from P_22 = P_33 = 0, ERRATA item 8).
struct ExactResponse
{
  double stress;   ///< the reported nominal stress component [kPa]
  double pressure; ///< Lagrange multiplier p
  double lateral;  ///< UTCTF: stretch along e2 (otherwise NaN)
};
ExactResponse exact_response(const MaterialPointModel& model, LoadCase c,
                             double s);

/// The closed forms of the paper's appendix table (tab:analytical_responses)
/// with the corrections of ERRATA.md, where the paper gives one: all passive
/// cases, and active UTCAF.  Independent of the UFL: hand-written from the
/// table; omega_a from the paper's own formulas (Lambert W via Boost for WKM,
/// GIANT's implicit equation with a bracketing solver and central differences
/// as in the paper, COMBI's explicit formula).
std::optional<double> paper_response(const ParameterSet& p, LoadCase c,
                                     MuscleState state, double s);

/// The paper's four models: the laws whose files declare DEFAULT_FOR "paper"
/// (ble, combi, giant, wkm, in file-name order), those paper_response knows and the
/// load-case study runs by default.
const std::vector<Model>& paper_models();

} // namespace muscle
