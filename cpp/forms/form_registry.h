#pragma once

#include <string>
#include <ufcx.h>
#include <vector>

/// The tables generated from the law files (forms/compile_forms.py writes the .cpp):
/// the material laws, and the FFCx-generated code of their kernels.
namespace muscle::forms
{

/// One parameter of a law: preset and admissible range (law file's PARAMETERS).
struct ParameterInfo
{
  const char* name;
  double preset;
  double lower;
  double upper;
  bool lower_open;
  bool upper_open;
  const char* unit; ///< mm, s, kPa (= mN/mm^2), mN; "-" if dimensionless
  const char* meaning;
};

/// A material law as its file declares it (forms/muscleforms/law.py).
struct LawInfo
{
  const char* name;
  const char* description; ///< the file's first docstring line
  const char* source;      ///< the law file
  std::vector<ParameterInfo> parameters; ///< the law's, then its time function's
  const char* drive;         ///< "none", "level" (time factor x scale) or "omega_kernel"
  const char* time_function; ///< "none", "tanh" or "twitch_train"
  const char* omega_kernel;  ///< the C++ quadrature-point kernel (omega_kernels()) or ""
  int taylor_order;          ///< derivatives of omega_a the forms read
  bool stress_holds_omega;   ///< the stress treats omega_a as fixed (WKM, eq. S_WKM)
  const char* passive;       ///< kernel set of the passive state
  bool anti_locking;         ///< has the Q1 with the volumetric part on one point
  std::vector<const char*> fit_parameters; ///< freed by the fit by default
  /// DEFAULT_FOR: the roles in which a program takes this law when none is named
  /// ("muscle", "fit", "paper"; forms/muscleforms/law.py ROLES)
  std::vector<const char*> default_for;
};

/// Every law, in file-name order.
const std::vector<LawInfo>& laws();

/// The omega kernels as the build read them from cpp/material/activation_kernels.cpp
/// (MUSCLE_OMEGA_KERNEL lines); the C++ registry is muscle::omega_kernels().
const std::vector<const char*>& registered_omega_kernels();

/// The F-bar hexahedron's own kernels (forms/muscleforms/fbar.py): a mixed
/// element on (u, J0) whose J0 = det F at the centre C++ eliminates per cell.
struct FbarForms
{
  ufcx_form* residual;   ///< (R_u, r_0) of the mixed element
  ufcx_form* jacobian;   ///< 25 x 25 on (u, J0)
  ufcx_form* r0;         ///< functional: r_0 alone (what the Jacobian needs of R)
  ufcx_form* centre;     ///< functional: J0 of the cell
  ufcx_form* gradient;   ///< g = dJ0/du
  ufcx_form* hessian;    ///< G = d2J0/du2
  ufcx_expression* centre_dilatation; ///< J0 at the centre point, for the DG0 field
};

/// The Taylor-Hood element's blocks besides the displacement's own
/// (forms/muscleforms/taylor_hood.py): q = (theta, p), the continuous degree-1
/// field "th_state" of two components.
struct TaylorHoodForms
{
  ufcx_form* residual;    ///< R_q on q's test space
  ufcx_form* jacobian_uq; ///< dR_u/dq
  ufcx_form* jacobian_qu; ///< dR_q/du
  ufcx_form* jacobian_qq; ///< dR_q/dq
};

/// Finite-element kernels of one material model on one element type.
struct FeVariant
{
  const char* model;  ///< kernel set: a law's name, or "<law>_passive"
  const char* cell;   ///< hexahedron or tetrahedron
  int degree;         ///< Lagrange degree of the displacement
  int quadrature_degree;
  /// rule of the stiff volumetric part; < quadrature_degree: anti-locking
  /// (selective reduced integration)
  int volumetric_quadrature_degree;
  ufcx_form* residual;
  ufcx_form* jacobian;
  /// the stiff volumetric part on its own rule (anti-locking), else null: added
  /// to residual/jacobian cell by cell (FFCx 0.5 cannot mix rules in one integral)
  ufcx_form* residual_volumetric;
  ufcx_form* jacobian_volumetric;
  ufcx_form* volume; ///< functional: current volume
  ufcx_form* energy; ///< functional: strain energy (F-bar: at theta = J0(u))
  ufcx_function_space* (*function_space)(const char*); ///< spaces by coefficient name
  ufcx_expression* fibre_stretch; ///< at quadrature points (kernel input), or null
  ufcx_expression* post; ///< [lambda, sigma_m, von Mises, J] at quadrature points
  /// F-bar hexahedron, else null; then residual/jacobian only carry the cell data
  const FbarForms* fbar;
  /// Taylor-Hood element, else null; then residual/jacobian are the displacement
  /// block at the current (theta, p)
  const TaylorHoodForms* taylor_hood;
};

/// Energy, stress and tangent of a model at a cell-wise constant displacement
/// gradient H: the material-point view of the same UFL.
struct MaterialPointVariant
{
  const char* model;
  ufcx_expression* energy;
  ufcx_expression* stress;  ///< P = dPsi/dH (WKM: omega_a held fixed)
  ufcx_expression* tangent; ///< dP/dH, omega_a's dependence on lambda included
  ufcx_expression* fibre_stretch;
};

/// Laplace problem for fibre directions (fusiform: potential 0 on the
/// origin, 1 on the insertion; fibres along its gradient).
struct FibreVariant
{
  const char* cell;
  ufcx_form* laplace; ///< bilinear
  ufcx_form* rhs;     ///< linear, constant "source"
  ufcx_function_space* (*function_space)(const char*);
  ufcx_expression* gradient; ///< grad(potential) at the cell midpoint
};

/// External loads on one element type (forms/muscleforms/loads.py): each
/// surface load integrates over the facets tagged 1.
struct LoadVariant
{
  const char* cell;
  int degree;
  ufcx_form* pressure_residual; ///< follower pressure, constant "pressure"
  ufcx_form* pressure_jacobian;
  ufcx_form* traction_residual; ///< dead traction, constant vector "traction"
  ufcx_form* gravity_residual;  ///< DG0 "density" x constant vector "gravity"
  ufcx_form* area;              ///< functional: current area of the surface
  ufcx_form* mass;              ///< bilinear: DG0 "density" x du . v (dynamics)
  ufcx_function_space* (*function_space)(const char*);
};

const std::vector<FeVariant>& fe_variants();
const std::vector<LoadVariant>& load_variants();

/// The elements this build compiled, "hex1,hex2,tet1,tet2" (CMake's MUSCLE_ELEMENTS).
const char* compiled_elements();
/// The regular expression the compiled variants' names match ("": every variant;
/// CMake's MUSCLE_VARIANTS).
const char* compiled_variants();
/// "" if the element (cell "hexahedron" / "tetrahedron", degree) is compiled,
/// else a sentence saying that the build left it out and how to add it.
std::string element_not_compiled(const std::string& cell, int degree);
const std::vector<FibreVariant>& fibre_variants();
const std::vector<MaterialPointVariant>& material_point_variants();

/// The quadrature degree of the standard build for a cell ("hexahedron",
/// "tetrahedron") and displacement degree; -1 if there is none.
int default_quadrature_degree(const std::string& cell, int degree);

/// Look up a compiled variant; InputError listing what is available otherwise.
/// quadrature_degree < 0 selects the default for the element,
/// volumetric_quadrature_degree < 0 the same rule as the rest of the energy;
/// `fbar` selects the F-bar hexahedron, `taylor_hood` the mixed element.
const FeVariant& find_fe_variant(const std::string& model,
                                 const std::string& cell, int degree,
                                 int quadrature_degree = -1,
                                 int volumetric_quadrature_degree = -1, bool fbar = false,
                                 bool taylor_hood = false);
const MaterialPointVariant& find_material_point_variant(const std::string& model);

} // namespace muscle::forms
