#pragma once

#include "forms/form_registry.h"

#include <array>
#include <dolfinx/fem/Form.h>
#include <dolfinx/fem/Function.h>
#include <dolfinx/mesh/MeshTags.h>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace muscle
{

/// External loads on a body, each a form of its own (forms/muscleforms/loads.py)
/// added to the laws' residual and Jacobian: follower pressure and dead traction
/// on surfaces, gravity on every cell with a density.  The values follow
/// functions of time, set by set_time().
class Loads
{
public:
  /// `u`: the body's displacement (the load forms share its space).
  explicit Loads(std::shared_ptr<dolfinx::fem::Function<double>> u);

  /// Follower pressure (kPa) on the exterior facets `facets` (local indices):
  /// along the current normal, pushing for value > 0.
  void add_pressure(const std::string& name, const std::vector<std::int32_t>& facets,
                    std::function<double(double)> value);
  /// Dead traction `direction` x value(t) (kPa per reference area).
  void add_traction(const std::string& name, const std::vector<std::int32_t>& facets,
                    std::array<double, 3> direction, std::function<double(double)> value);
  /// Body force density x `g` x value(t); `density` (kg/mm^3) per local cell.
  void add_gravity(std::array<double, 3> g, std::function<double(double)> value,
                   const std::vector<double>& density);

  void set_time(double t);

  bool empty() const { return _loads.empty(); }
  /// Residual forms (R = internal - external: the loads enter with a minus).
  std::vector<std::shared_ptr<const dolfinx::fem::Form<double>>> residuals() const;
  /// Jacobian forms of the loads that depend on u (follower pressure).
  std::vector<std::shared_ptr<const dolfinx::fem::Form<double>>> jacobians() const;

  /// Current area of the surface of load `name` (mm^2, collective).
  double current_area(const std::string& name) const;
  /// "pressure on top, gravity, ..." for messages and summary.json.
  std::vector<std::string> describe() const;

private:
  struct Load
  {
    std::string name, kind;
    std::function<double(double)> value;
    std::array<double, 3> direction{};
    std::shared_ptr<dolfinx::fem::Constant<double>> constant;
    std::shared_ptr<dolfinx::mesh::MeshTags<std::int32_t>> tags;
    std::shared_ptr<dolfinx::fem::Form<double>> residual, jacobian, area;
  };
  /// Tags the facets 1 in l.tags, builds l.area; the forms' integration domains.
  std::map<dolfinx::fem::IntegralType, const dolfinx::mesh::MeshTags<int>*>
  on_surface(Load& l, const std::vector<std::int32_t>& facets) const;

  std::shared_ptr<dolfinx::fem::Function<double>> _u;
  const forms::LoadVariant* _variant;
  std::vector<Load> _loads;
};

/// A cell-wise constant (DG0) field of `density` (kg/mm^3) per local cell.
std::shared_ptr<dolfinx::fem::Function<double>>
density_function(std::shared_ptr<const dolfinx::mesh::Mesh> mesh,
                 const std::vector<double>& density);

/// The consistent mass form int rho du . v dV on V (forms/muscleforms/loads.py).
std::shared_ptr<dolfinx::fem::Form<double>>
mass_form(std::shared_ptr<const dolfinx::fem::FunctionSpace> V,
          std::shared_ptr<const dolfinx::fem::Function<double>> density);

} // namespace muscle
