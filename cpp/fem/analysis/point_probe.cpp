#include "fem/analysis/point_probe.h"

#include <dolfinx/geometry/BoundingBoxTree.h>
#include <dolfinx/geometry/utils.h>
#include <numeric>

using namespace dolfinx;

namespace muscle
{

PointProbe::PointProbe(std::shared_ptr<const fem::Function<double>> u,
                       const std::array<double, 3>& x)
    : _u(std::move(u)), _point(x)
{
  const mesh::Mesh& mesh = *_u->function_space()->mesh();
  MPI_Comm comm = mesh.comm();
  // owned cells only: a point in a ghost cell is found by the rank owning it
  std::vector<std::int32_t> cells(mesh.topology().index_map(3)->size_local());
  std::iota(cells.begin(), cells.end(), 0);
  double distance = std::numeric_limits<double>::max();
  if (!cells.empty())
  {
    geometry::BoundingBoxTree tree(mesh, 3, cells);
    const auto candidates = geometry::compute_collisions(tree, std::span<const double>(x));
    const auto inside = geometry::compute_colliding_cells(mesh, candidates, x);
    if (inside.num_links(0) > 0)
    {
      _cell = inside.links(0).front();
      distance = 0;
    }
    else
    {
      // the nearest cell, and on it the point nearest x
      geometry::BoundingBoxTree midpoints
          = geometry::create_midpoint_tree(mesh, 3, std::span<const std::int32_t>(cells));
      _cell = geometry::compute_closest_entity(tree, midpoints, mesh, x).front();
      const std::vector<double> v
          = geometry::shortest_vector(mesh, 3, std::span<const std::int32_t>(&_cell, 1), x);
      distance = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
      for (int d = 0; d < 3; ++d)
        _point[d] = x[d] - v[d];
    }
  }
  struct
  {
    double distance;
    int rank;
  } local{distance, dolfinx::MPI::rank(comm)}, best;
  MPI_Allreduce(&local, &best, 1, MPI_DOUBLE_INT, MPI_MINLOC, comm);
  _owner = best.rank;
  _distance = best.distance;
  MPI_Bcast(_point.data(), 3, MPI_DOUBLE, _owner, comm);
}

std::array<double, 3> PointProbe::displacement() const
{
  const mesh::Mesh& mesh = *_u->function_space()->mesh();
  std::array<double, 3> value = {0, 0, 0};
  if (dolfinx::MPI::rank(mesh.comm()) == _owner)
    _u->eval(_point, {1, 3}, std::span<const std::int32_t>(&_cell, 1), value, {1, 3});
  MPI_Bcast(value.data(), 3, MPI_DOUBLE, _owner, mesh.comm());
  return value;
}

} // namespace muscle
