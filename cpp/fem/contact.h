#pragma once

#include "nonlinear_solver.h"
#include "surface_facets.h"

#include <dolfinx/fem/Function.h>
#include <memory>
#include <string>
#include <vector>

namespace muscle
{

/// Frictionless penalty contact between two surfaces of deformable bodies,
/// Gauss point to segment: every quadrature point of the slave surface (3 x 3 per
/// quadrilateral) is projected onto the master surface in the current
/// configuration; a negative gap g adds the energy eps/2 g^2 per area, with the
/// exact residual and tangent of contact_kernel.h.  The master surface is
/// gathered on every rank at each evaluation, so the two surfaces may sit on
/// different ranks.  Degree-1 elements.
class ContactPair : public NonlinearTerm
{
public:
  struct Settings
  {
    std::string name;                 ///< for messages: "contact[0]"
    std::vector<std::int32_t> slave;  ///< local facets
    std::vector<std::int32_t> master; ///< local facets
    double penalty;                   ///< eps [kPa/mm]
    double search_distance;           ///< largest slave-to-master distance considered [mm]
  };

  /// `fixed`: local unrolled dofs with a Dirichlet condition (sorted): their rows
  /// and columns get nothing.  InputError if a surface has no facets on any rank
  /// or the two surfaces never face each other.  Collective.
  ContactPair(std::shared_ptr<const dolfinx::fem::Function<double>> u, Settings settings,
              const std::vector<std::int32_t>& fixed);

  void add_residual(Vec F) override;
  void add_jacobian(Mat A) override;
  std::string diagnosis() const override;

  /// At the current displacement (collective).
  struct Measures
  {
    Point force{};            ///< on the slave body, mN
    double area = 0;          ///< of the slave points in contact (reference), mm^2
    double max_pressure = 0;  ///< kPa, the largest mean over a slave facet's points in contact
    double max_penetration = 0; ///< mm
    std::int64_t points = 0;  ///< slave points in contact
  };
  Measures measure();

  const Settings& settings() const { return _settings; }

private:
  using Facet = LocalSurfaceFacet;
  struct QuadraturePoint
  {
    std::size_t facet;
    std::array<double, 4> N;
    double weight; ///< reference area
  };
  /// A master facet in the current configuration, with its dofs' fixedness.
  struct Master
  {
    SurfaceFacet current;
    int orientation;
    std::array<bool, 12> fixed;
  };

  SurfaceFacet current(const Facet& f) const;
  /// Global dofs of a contact point's [slave | master] nodes; -1 where fixed.
  std::vector<PetscInt> global_dofs(const Facet& s, const Master& m) const;
  std::vector<Master> gather_master() const;
  /// Visit the slave points in contact: f(point, slave facet (current), master, result)
  template <typename F>
  void for_each_contact(F&& f);

  std::shared_ptr<const dolfinx::fem::Function<double>> _u;
  Settings _settings;
  std::vector<Facet> _slave, _master;
  std::vector<QuadraturePoint> _points;
  std::vector<char> _fixed; ///< local unrolled dofs
  std::int64_t _active = 0, _previous_active = 0, _changed = 0, _evaluations = 0;
};

} // namespace muscle
