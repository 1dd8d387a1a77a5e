#include "fem/linear/rigid_body_modes.h"

#include "fem/constraints/constraint.h"
#include "fem/geometry/gather.h"

#include <algorithm>
#include <dolfinx/common/IndexMap.h>
#include <dolfinx/fem/DofMap.h>
#include <dolfinx/la/Vector.h>
#include <dolfinx/la/petsc.h>
#include <dolfinx/mesh/Mesh.h>
#include <limits>
#include <numeric>

using namespace dolfinx;

namespace muscle
{

MeshBodies mesh_bodies(const fem::FunctionSpace& V)
{
  const fem::DofMap& dofmap = *V.dofmap();
  auto map = dofmap.index_map;
  const std::int32_t n = map->size_local() + map->num_ghosts();
  // this rank's pieces: union-find over its cells (owned and ghost)
  std::vector<std::int32_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](std::int32_t i)
  {
    while (parent[i] != i)
      i = parent[i] = parent[parent[i]];
    return i;
  };
  const int tdim = V.mesh()->topology().dim();
  auto cells = V.mesh()->topology().index_map(tdim);
  const std::int32_t num_cells = cells->size_local() + cells->num_ghosts();
  for (std::int32_t c = 0; c < num_cells; ++c)
  {
    auto dofs = dofmap.cell_dofs(c);
    for (std::size_t j = 1; j < dofs.size(); ++j)
      parent[find(dofs[j])] = find(dofs[0]);
  }
  // a body's label: the smallest global node index in it, passed between the
  // ranks sharing a node until no rank finds a smaller one (a body spread over
  // r ranks takes at most about r rounds)
  std::vector<std::int64_t> global(n);
  std::vector<std::int32_t> local(n);
  std::iota(local.begin(), local.end(), 0);
  map->local_to_global(local, global);
  la::Vector<double> label(map, 1);
  std::span<double> l = label.mutable_array();
  for (std::int32_t i = 0; i < n; ++i)
    l[i] = static_cast<double>(global[i]); // exact below 2^53 nodes
  auto smaller = [](double a, double b) { return std::min(a, b); };
  for (int changed = 1; changed;)
  {
    const std::vector<double> before(l.begin(), l.end());
    std::vector<double> piece(n, std::numeric_limits<double>::infinity());
    for (std::int32_t i = 0; i < n; ++i)
      piece[find(i)] = std::min(piece[find(i)], l[i]);
    for (std::int32_t i = 0; i < n; ++i)
      l[i] = piece[find(i)];
    label.scatter_rev(smaller);
    label.scatter_fwd();
    changed = !std::equal(before.begin(), before.end(), l.begin());
    MPI_Allreduce(MPI_IN_PLACE, &changed, 1, MPI_INT, MPI_MAX, map->comm());
  }
  std::vector<double> mine(l.begin(), l.end());
  std::sort(mine.begin(), mine.end());
  mine.erase(std::unique(mine.begin(), mine.end()), mine.end());
  std::vector<double> labels = gather_all(map->comm(), mine);
  std::sort(labels.begin(), labels.end());
  labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
  MeshBodies bodies;
  bodies.count = labels.size();
  bodies.of_node.resize(n);
  for (std::int32_t i = 0; i < n; ++i)
    bodies.of_node[i] = std::lower_bound(labels.begin(), labels.end(), l[i]) - labels.begin();
  return bodies;
}

MatNullSpace rigid_body_modes(const fem::FunctionSpace& V,
                              const DisplacementConstraint* constraint, bool per_body)
{
  auto map = V.dofmap()->index_map;
  const int bs = V.dofmap()->index_map_bs();
  const std::int32_t n = map->size_local();
  MeshBodies bodies;
  if (per_body)
    bodies = mesh_bodies(V);
  else
  {
    bodies.count = 1;
    bodies.of_node.assign(n, 0);
  }
  std::vector<la::Vector<double>> basis(6 * bodies.count, la::Vector<double>(map, bs));
  const std::vector<double> x = V.tabulate_dof_coordinates(false);
  for (std::int32_t i = 0; i < n; ++i)
  {
    const double* p = x.data() + 3 * i;
    la::Vector<double>* b = basis.data() + 6 * bodies.of_node[i];
    for (int k = 0; k < 3; ++k)
      b[k].mutable_array()[3 * i + k] = 1;
    // rotations about e3, e1, e2
    b[3].mutable_array()[3 * i + 0] = -p[1];
    b[3].mutable_array()[3 * i + 1] = p[0];
    b[4].mutable_array()[3 * i + 1] = -p[2];
    b[4].mutable_array()[3 * i + 2] = p[1];
    b[5].mutable_array()[3 * i + 0] = p[2];
    b[5].mutable_array()[3 * i + 2] = -p[0];
  }
  // PETSc-owned copies: the null space outlives `basis` (a wrapped array would
  // dangle, and GAMG would coarsen with whatever reuses that memory)
  std::vector<Vec> vecs;
  for (auto& b : basis)
  {
    Vec copy;
    if (constraint)
    {
      b.scatter_fwd();
      copy = constraint->create_reduced_vector();
      constraint->restrict_to(b, copy);
    }
    else
    {
      Vec wrap = la::petsc::create_vector_wrap(b);
      VecDuplicate(wrap, &copy);
      VecCopy(wrap, copy);
      VecDestroy(&wrap);
    }
    vecs.push_back(copy);
  }
  // PETSc asks for an orthonormal basis: Gram-Schmidt, twice for round-off.  A
  // mode the constraint made dependent on the others (a body reduced to a
  // few unknowns) is dropped.
  std::vector<Vec> kept;
  for (Vec v : vecs)
  {
    PetscReal start, norm;
    VecNorm(v, NORM_2, &start);
    for (int pass = 0; pass < 2; ++pass)
      for (Vec w : kept)
      {
        PetscScalar d;
        VecDot(v, w, &d);
        VecAXPY(v, -d, w);
      }
    VecNorm(v, NORM_2, &norm);
    if (norm > 1e-8 * start)
    {
      VecScale(v, 1 / norm);
      kept.push_back(v);
    }
    else
      VecDestroy(&v);
  }
  MatNullSpace ns;
  MatNullSpaceCreate(map->comm(), PETSC_FALSE, kept.size(), kept.data(), &ns);
  for (Vec& v : kept)
    VecDestroy(&v);
  return ns;
}

} // namespace muscle
