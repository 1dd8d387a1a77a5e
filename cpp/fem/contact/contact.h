#pragma once

#include "fem/terms/term.h"
#include "fem/contact/contact_kernel.h"
#include "fem/geometry/surface_facets.h"

#include <dolfinx/fem/Function.h>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace muscle
{

/// Frictionless penalty contact between two surfaces of deformable bodies,
/// Gauss point to segment: every quadrature point of the slave surface (3 x 3 per
/// quadrilateral) is projected onto the master surface in the current
/// configuration; a negative gap g gives the pressure eps (-g), along the
/// master's averaged nodal normals (Settings::smooth_normals) or as the gradient
/// of the energy eps/2 g^2 per area, with the residual and tangent of
/// contact_kernel.h.  The master surface is gathered on
/// every rank at each evaluation, so the two surfaces may sit on different
/// ranks; a k-d tree over its facet centres (nanoflann, rebuilt at every
/// evaluation) gives each slave point its candidate facets.  Degree-1 elements.
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
    /// force along the master's averaged nodal normals (contact_kernel.h);
    /// false: along the facet normal (the exact energy gradient)
    bool smooth_normals = true;
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

  /// Adds, per local node (displacement block) of the slave surface, the
  /// area weights sum w N_i, sum w N_i g and sum w N_i p (p = eps <-g>) over the
  /// slave points facing the master within the search distance.
  void add_nodal_sums(std::span<double> weight, std::span<double> gap,
                      std::span<double> pressure);

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
    /// outward unit normals at the nodes: the area-weighted mean of the normals
    /// of the facets around the node that lie within the feature angle of this
    /// facet's (an edge of a block stays sharp)
    std::array<Point, 4> corner_normal;
    std::array<double, 4> corner_length;             ///< |sum of the ring's normals|
    std::array<std::vector<std::size_t>, 4> ring;    ///< facets averaged at each corner
  };

  SurfaceFacet current(const Facet& f) const;
  /// Global dofs of a contact point's [slave | master] nodes; -1 where fixed.
  std::vector<PetscInt> global_dofs(const Facet& s, const Master& m) const;
  std::vector<Master> gather_master() const;
  /// The tangent of the corner normals' motion (smooth normals): rows the
  /// contact point's [slave | master] dofs, columns the nodes of the rings.
  void add_normal_motion(Mat A, const QuadraturePoint& q, const std::vector<PetscInt>& rows,
                         const Master& m, const ContactPoint& p);
  /// Visit the slave points in contact: f(point, slave facet, master (current), result)
  /// `with_open`: also the points facing the master within the search
  /// distance but not in contact (g > 0)
  template <typename F>
  void for_each_contact(F&& f, bool with_open = false);

  std::shared_ptr<const dolfinx::fem::Function<double>> _u;
  Settings _settings;
  std::vector<Facet> _slave, _master;
  std::vector<Master> _gathered; ///< the master surface of the last evaluation
  std::vector<QuadraturePoint> _points;
  std::vector<char> _fixed; ///< local unrolled dofs
  std::int64_t _active = 0, _previous_active = 0, _changed = 0, _evaluations = 0;
};

/// Contact pressure (kPa) and gap (mm) as nodal fields for the XDMF output:
/// area-weighted means over the slave points around each node; the gap is the
/// search distance where no master facet is within reach.
class ContactFields
{
public:
  explicit ContactFields(const dolfinx::fem::FunctionSpace& V);
  /// Collective.
  void update(const std::vector<std::shared_ptr<ContactPair>>& pairs);
  std::shared_ptr<dolfinx::fem::Function<double>> pressure, gap;

private:
  std::shared_ptr<dolfinx::fem::FunctionSpace> _space;
  std::shared_ptr<dolfinx::la::Vector<double>> _w;
  std::vector<std::int32_t> _node; ///< scalar dof -> displacement block
  std::size_t _blocks = 0;         ///< local displacement blocks (owned and ghost)
};

} // namespace muscle
