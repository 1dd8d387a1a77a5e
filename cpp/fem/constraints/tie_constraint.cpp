#include "fem/constraints/tie_constraint.h"

#include "common/errors.h"
#include "fem/geometry/gather.h"
#include "fem/geometry/surface_facets.h"

#include <algorithm>
#include <cmath>
#include <dolfinx/common/IndexMap.h>
#include <dolfinx/common/MPI.h>
#include <dolfinx/fem/DofMap.h>
#include <dolfinx/fem/DirichletBC.h>
#include <dolfinx/fem/utils.h>
#include <dolfinx/mesh/Mesh.h>
#include <limits>
#include <map>
#include <numeric>
#include <petscvec.h>
#include <unordered_map>
#include <unordered_set>

using namespace dolfinx;

namespace muscle
{
namespace
{

/// This rank's owned facets of a surface, in reference coordinates.
std::vector<SurfaceFacet> owned_facets(const fem::FunctionSpace& V,
                                       const std::vector<std::int32_t>& facets,
                                       const std::string& name)
{
  std::vector<SurfaceFacet> out;
  for (const LocalSurfaceFacet& f : owned_surface_facets(V, facets, name))
    out.push_back(f.reference);
  return out;
}

/// Every rank's facets, on every rank.
std::vector<SurfaceFacet> gather_facets(MPI_Comm comm, const std::vector<SurfaceFacet>& local)
{
  std::vector<double> packed;
  for (const SurfaceFacet& f : local)
  {
    packed.push_back(f.n);
    for (int k = 0; k < f.n; ++k)
      packed.insert(packed.end(), {f.x[k][0], f.x[k][1], f.x[k][2], double(f.node[k])});
  }
  const std::vector<double> all = gather_all(comm, packed);
  std::vector<SurfaceFacet> out;
  for (std::size_t i = 0; i < all.size();)
  {
    SurfaceFacet f;
    f.n = static_cast<int>(all[i++]);
    for (int k = 0; k < f.n; ++k, i += 4)
    {
      f.x[k] = {all[i], all[i + 1], all[i + 2]};
      f.node[k] = static_cast<std::int64_t>(all[i + 3]);
    }
    out.push_back(f);
  }
  return out;
}

/// The same InputError on every rank: the first rank's message that has one.
void fail_together(MPI_Comm comm, const std::string& message)
{
  int rank, first;
  MPI_Comm_rank(comm, &rank);
  const int mine = message.empty() ? std::numeric_limits<int>::max() : rank;
  MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, comm);
  if (first == std::numeric_limits<int>::max())
    return;
  int length = message.size();
  MPI_Bcast(&length, 1, MPI_INT, first, comm);
  std::string text = rank == first ? message : std::string(length, ' ');
  MPI_Bcast(text.data(), length, MPI_CHAR, first, comm);
  throw InputError(text);
}

std::string fmt(const Point& p)
{
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, "(%.6g, %.6g, %.6g)", p[0], p[1], p[2]);
  return buffer;
}
} // namespace

TieConstraint::TieConstraint(const fem::FunctionSpace& V, const std::vector<Pair>& pairs,
                             const std::vector<std::int32_t>& fixed)
{
  auto mesh = V.mesh();
  MPI_Comm comm = mesh->comm();
  auto map = V.dofmap()->index_map;
  const int bs = V.dofmap()->index_map_bs();
  const std::int32_t owned_blocks = map->size_local();
  const std::int64_t first_block = map->local_range()[0];
  _num_owned = bs * owned_blocks;
  const int tdim = mesh->topology().dim();
  auto& topology = const_cast<mesh::Topology&>(mesh->topology());
  topology.create_connectivity(tdim - 1, tdim);
  topology.create_connectivity(tdim, tdim - 1);
  const std::vector<double> coords = V.tabulate_dof_coordinates(false);

  // each owned slave node: its master nodes and weights
  using Row = std::vector<std::pair<std::int64_t, double>>; // master node, weight
  std::unordered_map<std::int32_t, Row> rows; // owned block -> row
  std::unordered_set<std::int64_t> master_nodes;
  std::string error;
  double gap = 0;
  for (const Pair& pair : pairs)
  {
    const std::vector<SurfaceFacet> master
        = gather_facets(comm, owned_facets(V, pair.master, pair.name));
    if (master.empty())
      throw InputError(pair.name + ": the master surface has no facets");
    for (const SurfaceFacet& f : master)
      master_nodes.insert(f.node.begin(), f.node.begin() + f.n);
    // dual mortar: each slave node's integrals of psi_s N_m, summed over its facets
    std::map<std::int64_t, std::map<std::int64_t, double>> mortar;
    const auto triples = dual_mortar(owned_facets(V, pair.slave, pair.name), master,
                                     pair.tolerance);
    std::vector<double> packed;
    for (const auto& [s, m, v] : triples)
      packed.insert(packed.end(), {double(s), double(m), v});
    const std::vector<double> all = gather_all(comm, packed);
    for (std::size_t i = 0; i < all.size(); i += 3)
      mortar[std::int64_t(all[i])][std::int64_t(all[i + 1])] += all[i + 2];

    const std::vector<std::int32_t> slave
        = fem::locate_dofs_topological(V, tdim - 1, pair.slave);
    for (std::int32_t b : slave)
    {
      if (b >= owned_blocks)
        continue;
      const std::int64_t global = first_block + b;
      if (master_nodes.count(global))
        continue; // a node of both surfaces: glued already
      const Point p = {coords[3 * b], coords[3 * b + 1], coords[3 * b + 2]};
      double best = std::numeric_limits<double>::infinity();
      Row nearest;
      for (const SurfaceFacet& f : master)
      {
        const auto [d, w] = closest_point(f, p);
        if (d < best)
        {
          best = d;
          nearest.clear();
          for (int k = 0; k < f.n; ++k)
            nearest.emplace_back(f.node[k], w[k]);
        }
      }
      if (best > pair.tolerance and error.empty())
        error = pair.name + ": the slave node at " + fmt(p) + " lies "
                + std::to_string(best) + " mm from the master surface, more than the "
                + "tolerance " + std::to_string(pair.tolerance)
                + " mm: are the surfaces in contact in the reference configuration?";
      if (rows.count(b) and error.empty())
        error = pair.name + ": the node at " + fmt(p) + " is the slave of two ties";
      gap = std::max(gap, best);
      // the mortar row, normalised so that it moves rigidly with the master; a
      // node the mortar integrals miss (an edge beyond the master) follows the
      // nearest master point
      Row row;
      double sum = 0, scale = 0;
      if (auto it = mortar.find(global); it != mortar.end())
        for (const auto& [m, v] : it->second)
        {
          row.emplace_back(m, v);
          sum += v;
          scale += std::abs(v);
        }
      if (!(sum > 1e-10 * scale) or scale == 0)
        row = nearest;
      else
        for (auto& [m, v] : row)
          v /= sum;
      rows[b] = row;
    }
  }
  fail_together(comm, error);

  // reduced numbering: every owned dof but the slaves' (a fixed component of a
  // slave node stays an unknown of its own, held by its Dirichlet condition)
  auto is_fixed = [&](std::int32_t dof)
  { return std::binary_search(fixed.begin(), fixed.end(), dof); };
  auto is_slave = [&](std::int32_t dof) { return rows.count(dof / bs) and !is_fixed(dof); };
  std::int64_t n = 0;
  _reduced_index.assign(_num_owned, -1);
  for (std::int32_t i = 0; i < _num_owned; ++i)
    if (!is_slave(i))
      _reduced_index[i] = n++;
  int whole = 1;
  for (std::int32_t b = 0; b < owned_blocks; ++b)
  {
    int slaves = 0;
    for (int k = 0; k < bs; ++k)
      slaves += is_slave(bs * b + k);
    whole = whole and (slaves == 0 or slaves == bs);
  }
  MPI_Allreduce(MPI_IN_PLACE, &whole, 1, MPI_INT, MPI_MIN, comm);
  _whole_nodes = whole;
  std::int64_t offset = 0;
  MPI_Exscan(&n, &offset, 1, MPI_INT64_T, MPI_SUM, comm);
  int rank;
  MPI_Comm_rank(comm, &rank);
  if (rank == 0)
    offset = 0;

  // the master dofs' reduced numbers, from their owners
  std::vector<std::int64_t> pairs_out;
  for (std::int32_t b = 0; b < owned_blocks; ++b)
    if (master_nodes.count(first_block + b))
      for (int k = 0; k < bs; ++k)
      {
        if (is_slave(bs * b + k) and error.empty())
          error = "tie: the node at "
                  + fmt({coords[3 * b], coords[3 * b + 1], coords[3 * b + 2]})
                  + " is both a slave and a master node";
        pairs_out.insert(pairs_out.end(),
                         {bs * (first_block + b) + k, offset + _reduced_index[bs * b + k]});
      }
  fail_together(comm, error);
  const std::vector<std::int64_t> all = gather_all(comm, pairs_out);
  std::unordered_map<std::int64_t, std::int64_t> reduced_of;
  for (std::size_t i = 0; i < all.size(); i += 2)
    reduced_of[all[i]] = all[i + 1];

  MatCreateAIJ(comm, _num_owned, n, PETSC_DETERMINE, PETSC_DETERMINE, 16, nullptr, 16, nullptr,
               _T.out());
  MatSetOption(_T, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE);
  const PetscInt row0 = bs * first_block;
  for (std::int32_t i = 0; i < _num_owned; ++i)
  {
    if (!is_slave(i))
    {
      MatSetValue(_T, row0 + i, offset + _reduced_index[i], 1.0, INSERT_VALUES);
      continue;
    }
    for (const auto& [m, w] : rows.at(i / bs))
      if (w != 0)
        MatSetValue(_T, row0 + i, reduced_of.at(bs * m + i % bs), w, INSERT_VALUES);
  }
  MatAssemblyBegin(_T, MAT_FINAL_ASSEMBLY);
  MatAssemblyEnd(_T, MAT_FINAL_ASSEMBLY);

  std::int64_t local_slaves = rows.size();
  MPI_Allreduce(&local_slaves, &_slave_nodes, 1, MPI_INT64_T, MPI_SUM, comm);
  MPI_Allreduce(&gap, &_largest_gap, 1, MPI_DOUBLE, MPI_MAX, comm);
}

void TieConstraint::restrict_to(const la::Vector<double>& u, Vec x) const
{
  PetscScalar* xr;
  VecGetArray(x, &xr);
  copy_free_dofs(u, xr);
  VecRestoreArray(x, &xr);
}

} // namespace muscle
