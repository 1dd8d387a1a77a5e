#pragma once

#include "fem/newton/nonlinear_solver.h"
#include "fem/time/time_stepping.h"
#include "material/activation_kernels.h"
#include "material/parameters.h"
#include "scene/expression.h"

#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace muscle
{

/// Where a value came from in a scene file, for messages.
struct SceneLocation
{
  std::string file;
  int line = 0;   ///< 1-based; 0 unknown
  std::string key; ///< dotted path, e.g. parts[0].material.model
  std::string text() const;
};

/// A function of time: the material's own activation (tanh for BLE/COMBI, the
/// twitch train for WKM/GIANT), a constant, a linear ramp, a piecewise-linear
/// table or a formula of t.
struct TimeFunction
{
  enum class Kind
  {
    model,
    constant,
    ramp,
    table,
    expression
  } kind = Kind::model;
  double value = 0;                         ///< constant; ramp end value
  double start = 0, duration = 0;           ///< ramp: 0 before start, value after
  std::vector<std::array<double, 2>> table; ///< (t, value), increasing t
  std::optional<Expression> formula;        ///< of t

  /// `model_factor` is the material's time factor at t (Kind::model only).
  double operator()(double t, double model_factor = 0) const;
};

/// The spatial distribution of the activation over the cells.
struct ActivationScale
{
  enum class Kind
  {
    constant,
    groups,     ///< per physical volume
    expression, ///< of x, y, z, t (re-evaluated every step if it uses t)
    file        ///< values at points, nearest point per cell, optionally in time
  } kind = Kind::constant;
  double value = 1;
  std::map<std::string, double> groups;
  double other = 0; ///< groups: cells in no listed group
  std::optional<Expression> formula;
  std::string path; ///< file: CSV x,y,z,scale or x,y,z,<t1>,<t2>...
  SceneLocation where;
};

struct FibreSpec
{
  enum class Kind
  {
    direction,
    laplace,
    file ///< CSV x,y,z,a1,a2,a3: nearest point per cell
  } kind = Kind::direction;
  std::array<double, 3> direction = {0, 0, 1};
  std::string from, to; ///< laplace: surface names
  std::string path;
  SceneLocation where;
};

struct Part
{
  std::string name;
  /// Volume groups of the mesh this part occupies; empty: the whole mesh
  /// (a single part).  Parts must not share a volume and must cover the mesh.
  std::vector<std::string> volumes;
  /// without a material: the law declared DEFAULT_FOR "muscle" (COMBI)
  ParameterSet parameters{default_model("muscle")};
  bool active = true; ///< false: passive forms only, no activation kernel
  double density = 0; ///< kg/mm^3 (1 g/cm^3 = 1e-6); 0: none given
  FibreSpec fibres;
  TimeFunction activation_time;
  ActivationScale activation_scale;
  SceneLocation where;
};

struct BoundaryCondition
{
  enum class Kind
  {
    clamp,
    displacement,   ///< one component prescribed, value(t) in mm
    uniform_axial,  ///< one component equal on the surface, unknown value
    point,          ///< the node nearest `at` fixed (all components)
  } kind = Kind::clamp;
  std::string surface;
  std::array<double, 3> at = {0, 0, 0}; ///< point: reference coordinates [mm]
  int component = 2;
  TimeFunction value; ///< displacement
  SceneLocation where;
};

/// An external load: follower pressure or dead traction on a surface, or gravity
/// on every part with a density; each scaled by a function of time.
struct LoadSpec
{
  enum class Kind
  {
    pressure, ///< kPa, follower (along the current normal, pushing for > 0)
    traction, ///< kPa per reference area, dead: vector x value(t)
    gravity   ///< mm/s^2: density x vector x value(t) per volume
  } kind = Kind::pressure;
  std::string surface; ///< pressure, traction
  std::array<double, 3> vector = {0, 0, 0};
  TimeFunction value; ///< pressure: kPa; traction, gravity: factor (default 1)
  SceneLocation where;
};

/// Two separately meshed surfaces glued: the slave's nodes follow the master.
struct TieSpec
{
  std::string slave, master;
  double tolerance = -1; ///< mm; < 0: a quarter of the mean element size
  SceneLocation where;
};

/// Frictionless penalty contact between two surfaces.
struct ContactSpec
{
  std::string slave, master;
  double penalty = -1; ///< kPa/mm; < 0: 10 x the stiffest tangent / element size
  bool smooth_normals = true; ///< force along averaged nodal normals (ContactPair)
  SceneLocation where;
};

/// One column of series.csv.
struct SeriesQuantity
{
  enum class Kind
  {
    activation,   ///< time factor of the first active part
    reaction,     ///< force the body exerts on a Dirichlet surface [mN]
    section_force,///< force through an interior surface [mN]
    displacement, ///< mean displacement of a surface's nodes [mm]
    stretch_ratio,///< 1 + displacement / length
    volume_change,///< V/V0 - 1
    min_J,        ///< smallest J at the quadrature points
    point,        ///< displacement (or position) of the material point nearest `at` [mm]
    contact_force,   ///< |resultant| of a contact pair's normal forces [mN]
    contact_area,    ///< area in contact [mm^2]
    max_pressure,    ///< largest contact pressure [kPa]
    max_penetration, ///< largest penetration [mm]
    rotation,        ///< rotation vector of a part's best rigid fit [degrees]
    kinetic_energy,  ///< 1/2 v^T M v (dynamic scenes) [µJ = mN mm]
    strain_energy    ///< the laws' energy over the body [µJ]
  } kind;
  int pair = 0; ///< contact quantities: index into Scene::contacts
  std::string part; ///< rotation: the part's name
  std::string name, surface;
  int component = 2;
  double length = 1; ///< stretch_ratio
  double sign = 1;   ///< reaction: +1 force on the body by the support
  std::array<double, 3> at = {0, 0, 0}; ///< point: reference coordinates [mm]
  bool position = false; ///< point: x + u instead of u
  SceneLocation where;
};

struct MeshSpec
{
  std::string path; ///< .geo or .msh, absolute
  std::map<std::string, double> numbers; ///< Gmsh -setnumber
  SceneLocation numbers_where;           ///< of the numbers (mesh.set), if given
  std::string cell = "hex";
  int degree = 1;
  int quadrature_degree = -1;
  int volumetric_quadrature_degree = -1; ///< 1 on Q1: anti-locking
  /// F-bar hexahedra (Q1) if given; unset: F-bar on degree-1 hexahedra
  /// (use_fbar), decided once the mesh's cells are known
  std::optional<bool> fbar;
  SceneLocation fbar_where; ///< of element.fbar, if given
  /// Taylor-Hood (degree 2: Q2-Q1, P2-P1), the pressure an unknown of its own
  bool taylor_hood = false;
  SceneLocation where;
};

struct OutputSpec
{
  std::vector<SeriesQuantity> series;
  bool fields = true;
  int fields_every = 1;
  bool plots = true;
  bool surface = true; ///< surface.json for tools/render_surface.py
  int checkpoint_every = 1;
};

/// Structural dynamics: the generalized-alpha method (cpp/fem/generalized_alpha.h)
/// with every part's density.  A scene without it is quasi-static.
struct DynamicsSpec
{
  double rho_inf = 1; ///< spectral radius at infinite frequency, [0, 1]; 1: no damping
  std::array<double, 3> initial_velocity = {0, 0, 0}; ///< mm/s, of every free node
  SceneLocation where;
};

struct Scene
{
  std::string file;   ///< the scene file
  std::string title;
  std::string text;   ///< verbatim
  std::vector<std::string> overrides; ///< the command line's --set KEY=VALUE, in order
  /// mesh, element, parts and boundary as read: what a checkpoint must match
  /// (time, solver and output settings may change between a stop and --resume)
  std::string physics;
  MeshSpec mesh;
  std::vector<Part> parts;
  std::vector<BoundaryCondition> boundary;
  std::vector<LoadSpec> loads;
  std::vector<TieSpec> ties;
  std::vector<ContactSpec> contacts;
  TimeSteppingOptions time;
  std::optional<DynamicsSpec> dynamics;
  NewtonOptions newton;
  bool line_search_given = false; ///< solver.line_search in the file (else the default)
  /// WKM/GIANT activation root finder: relative step tolerance (solver.root_tolerance)
  double root_tolerance = default_root_tolerance;
  std::vector<std::string> petsc_options;
  OutputSpec output;
};

/// Read and check a scene (nothing is meshed or solved).  Every mistake is an
/// InputError "FILE:LINE: KEY: what is wrong; what is allowed".  `overrides`
/// ("KEY=VALUE", KEY a dotted path with list indices such as
/// parts[0].material.parameters.kappa) replace or add values before the scene
/// is checked, with the same checks; their mistakes are located at "--set ...".
Scene read_scene(const std::string& path, const std::vector<std::string>& overrides = {});

/// The same from text; `name` is used in messages and relative paths are
/// resolved against `directory`.
Scene parse_scene(const std::string& text, const std::string& name,
                  const std::string& directory,
                  const std::vector<std::string>& overrides = {});

} // namespace muscle
