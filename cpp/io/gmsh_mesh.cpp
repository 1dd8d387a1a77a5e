#include "io/gmsh_mesh.h"

#include "common/errors.h"

#include <dolfinx/fem/CoordinateElement.h>
#include <dolfinx/graph/AdjacencyList.h>
#include <dolfinx/io/cells.h>
#include <dolfinx/io/xdmf_utils.h>
#include <dolfinx/mesh/utils.h>
#include <filesystem>
#include <gmsh.h>
#include <sstream>
#include <unistd.h>

using namespace dolfinx;

namespace muscle
{

int GmshMesh::surface(const std::string& name) const
{
  auto it = surfaces.find(name);
  if (it != surfaces.end())
    return it->second;
  std::vector<std::string> names;
  for (const auto& [n, t] : surfaces)
    names.push_back(n);
  throw InputError("mesh has no physical surface '" + name + "'"
                   + did_you_mean(name, names) + "; surfaces: " + join(names));
}

namespace
{
/// What rank 0 reads from Gmsh.
struct RawMesh
{
  int cell_type_gmsh = 0;
  std::vector<double> x;                 ///< node coordinates (n, 3)
  std::vector<std::int64_t> cells;       ///< dolfinx node order
  std::vector<std::int32_t> cell_marker; ///< volume physical tag per cell
  std::vector<std::int64_t> facets;      ///< dolfinx node order
  std::vector<std::int32_t> facet_marker;
  std::map<std::string, int> surfaces, volumes;
};

mesh::CellType dolfinx_cell(int gmsh_type)
{
  switch (gmsh_type)
  {
  case 5:
    return mesh::CellType::hexahedron;
  case 4:
    return mesh::CellType::tetrahedron;
  default:
    throw InputError("unsupported Gmsh cell type " + std::to_string(gmsh_type)
                     + ": linear hexahedra (5) or tetrahedra (4) only");
  }
}


/// Before a .geo is meshed in 3-D: the number of cells estimated from its 1-D
/// mesh (cells ~ bounding-box volume / h^3, h the median edge length, an
/// over-estimate for non-box shapes) and a refusal when even a lean 4 KiB per
/// cell (several times less than the fusiform runs take; BENCHMARKS.md, "Linear
/// solvers, ranks and n = 4")
/// exceeds this machine's memory -- a typo such as refinement 1000 would
/// otherwise mesh for hours.
void refuse_impossible_mesh(const std::string& path)
{
  gmsh::model::mesh::generate(1);
  std::vector<int> types;
  std::vector<std::vector<std::size_t>> tags, nodes;
  gmsh::model::mesh::getElements(types, tags, nodes, 1, -1);
  std::vector<std::size_t> node_tags;
  std::vector<double> x, parametric;
  gmsh::model::mesh::getNodes(node_tags, x, parametric, -1, -1, false, false);
  std::map<std::size_t, std::size_t> index;
  for (std::size_t i = 0; i < node_tags.size(); ++i)
    index[node_tags[i]] = 3 * i;
  std::vector<double> lengths;
  for (std::size_t t = 0; t < types.size(); ++t)
    for (std::size_t e = 0; e + 1 < nodes[t].size(); e += nodes[t].size() / tags[t].size())
    {
      const double* a = &x[index.at(nodes[t][e])];
      const double* b = &x[index.at(nodes[t][e + 1])];
      lengths.push_back(std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]));
    }
  if (lengths.empty())
    return;
  std::nth_element(lengths.begin(), lengths.begin() + lengths.size() / 2, lengths.end());
  const double h = lengths[lengths.size() / 2];
  double x0, y0, z0, x1, y1, z1;
  gmsh::model::getBoundingBox(-1, -1, x0, y0, z0, x1, y1, z1);
  if (!(h > 0))
    return;
  const double cells = (x1 - x0) * (y1 - y0) * (z1 - z0) / (h * h * h);
  const double needed = 4096.0 * cells;
  const double memory = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGE_SIZE));
  if (needed > memory)
  {
    char text[400];
    std::snprintf(text, sizeof text,
                  "%s: the mesh would have about %.3g cells (median edge %.3g mm in a %.3g x "
                  "%.3g x %.3g mm box), at least %.3g GiB at 4 KiB per cell, more than this "
                  "machine's %.3g GiB: lower the refinement (mesh.set)",
                  path.c_str(), cells, h, x1 - x0, y1 - y0, z1 - z0, needed / 1073741824.0,
                  memory / 1073741824.0);
    throw InputError(text);
  }
}

RawMesh read_on_root(const std::string& path, const std::map<std::string, double>& numbers)
{
  std::error_code error;
  if (!std::filesystem::exists(path, error))
    throw InputError("mesh file '" + path + "' does not exist");
  std::vector<std::string> args = {"muscle"};
  for (const auto& [name, value] : numbers)
  {
    std::ostringstream v;
    v.precision(17);
    v << value;
    args.insert(args.end(), {"-setnumber", name, v.str()});
  }
  std::vector<char*> argv;
  for (std::string& a : args)
    argv.push_back(a.data());
  gmsh::initialize(static_cast<int>(argv.size()), argv.data(), false);
  gmsh::option::setNumber("General.Terminal", 0);
  RawMesh raw;
  try
  {
    gmsh::open(path);
    if (std::filesystem::path(path).extension() == ".geo")
    {
      refuse_impossible_mesh(path);
      gmsh::model::mesh::generate(3);
    }

    std::vector<std::size_t> node_tags;
    std::vector<double> coords, parametric;
    gmsh::model::mesh::getNodes(node_tags, coords, parametric, -1, -1, false, false);
    std::map<std::size_t, std::int64_t> index;
    for (std::size_t i = 0; i < node_tags.size(); ++i)
      index[node_tags[i]] = i;
    raw.x = coords;

    gmsh::vectorpair groups;
    gmsh::model::getPhysicalGroups(groups);
    for (auto [dim, tag] : groups)
    {
      std::string name;
      gmsh::model::getPhysicalName(dim, tag, name);
      if (name.empty())
        name = "group" + std::to_string(tag);
      std::vector<int> entities;
      gmsh::model::getEntitiesForPhysicalGroup(dim, tag, entities);
      for (int entity : entities)
      {
        std::vector<int> types;
        std::vector<std::vector<std::size_t>> element_tags, element_nodes;
        gmsh::model::mesh::getElements(types, element_tags, element_nodes, dim, entity);
        for (std::size_t k = 0; k < types.size(); ++k)
        {
          if (dim == 3)
          {
            if (raw.cell_type_gmsh != 0 and raw.cell_type_gmsh != types[k])
              throw InputError(path + ": mixed cell types are not supported");
            raw.cell_type_gmsh = types[k];
          }
          const int n = dim == 3 ? (types[k] == 5 ? 8 : 4) : (types[k] == 3 ? 4 : 3);
          const mesh::CellType ct
              = dim == 3 ? dolfinx_cell(types[k])
                         : (types[k] == 3 ? mesh::CellType::quadrilateral
                                          : mesh::CellType::triangle);
          if ((dim == 3 and types[k] != 4 and types[k] != 5)
              or (dim == 2 and types[k] != 2 and types[k] != 3))
          {
            throw InputError(path + ": element type " + std::to_string(types[k])
                             + " in physical group '" + name
                             + "' (linear cells and facets only)");
          }
          const std::vector<std::uint8_t> perm = io::cells::perm_gmsh(ct, n);
          auto& target = dim == 3 ? raw.cells : raw.facets;
          auto& marker = dim == 3 ? raw.cell_marker : raw.facet_marker;
          for (std::size_t e = 0; e < element_tags[k].size(); ++e)
          {
            for (int i = 0; i < n; ++i)
              target.push_back(index.at(element_nodes[k][n * e + perm[i]]));
            marker.push_back(tag);
          }
        }
      }
      (dim == 3 ? raw.volumes : raw.surfaces)[name] = tag;
    }
  }
  catch (const InputError&)
  {
    gmsh::finalize();
    throw;
  }
  catch (const std::exception& e)
  {
    gmsh::finalize();
    throw InputError("Gmsh could not read '" + path + "': " + e.what());
  }
  gmsh::finalize();
  if (raw.cells.empty())
    throw InputError(path + ": no 3-D cells in a physical volume (define a Physical Volume)");

  // Keep only the nodes of cells, numbered contiguously: construction points
  // outside every cell would otherwise be "input nodes" DOLFINx never sees.
  std::vector<std::int64_t> renumber(raw.x.size() / 3, -1);
  std::vector<double> x;
  for (std::int64_t& node : raw.cells)
  {
    if (renumber[node] < 0)
    {
      renumber[node] = x.size() / 3;
      x.insert(x.end(), raw.x.begin() + 3 * node, raw.x.begin() + 3 * node + 3);
    }
    node = renumber[node];
  }
  for (std::int64_t& node : raw.facets)
  {
    if (renumber[node] < 0)
      throw InputError(path + ": a tagged surface has a node that belongs to no cell");
    node = renumber[node];
  }
  raw.x = std::move(x);
  return raw;
}

/// Broadcast a vector from rank 0.
template <typename T>
void broadcast(MPI_Comm comm, std::vector<T>& v)
{
  std::uint64_t n = v.size();
  MPI_Bcast(&n, 1, MPI_UINT64_T, 0, comm);
  v.resize(n);
  MPI_Bcast(v.data(), static_cast<int>(n * sizeof(T)), MPI_BYTE, 0, comm);
}

void broadcast(MPI_Comm comm, std::map<std::string, int>& m)
{
  std::string text;
  for (const auto& [k, v] : m)
    text += k + "\n" + std::to_string(v) + "\n";
  std::vector<char> buffer(text.begin(), text.end());
  broadcast(comm, buffer);
  std::istringstream in(std::string(buffer.begin(), buffer.end()));
  m.clear();
  for (std::string key, value; std::getline(in, key) and std::getline(in, value);)
    m[key] = std::stoi(value);
}
} // namespace

GmshMesh read_gmsh(MPI_Comm comm, const std::string& path,
                   const std::map<std::string, double>& numbers)
{
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  RawMesh raw;
  std::string error;
  if (rank == 0)
  {
    try
    {
      raw = read_on_root(path, numbers);
    }
    catch (const InputError& e)
    {
      error = e.what();
    }
  }
  std::vector<char> message(error.begin(), error.end());
  broadcast(comm, message);
  if (!message.empty())
    throw InputError(std::string(message.begin(), message.end()));
  MPI_Bcast(&raw.cell_type_gmsh, 1, MPI_INT, 0, comm);
  broadcast(comm, raw.surfaces);
  broadcast(comm, raw.volumes);
  // cell markers by original index, on every rank (one int per cell)
  broadcast(comm, raw.cell_marker);

  const mesh::CellType cell_type = dolfinx_cell(raw.cell_type_gmsh);
  const int nodes_per_cell = mesh::num_cell_vertices(cell_type);
  GmshMesh out;
  std::int64_t counts[2] = {static_cast<std::int64_t>(raw.x.size() / 3),
                            static_cast<std::int64_t>(raw.cells.size() / nodes_per_cell)};
  MPI_Bcast(counts, 2, MPI_INT64_T, 0, comm);
  out.num_nodes = counts[0];
  out.num_cells = counts[1];
  out.surfaces = raw.surfaces;
  out.volumes = raw.volumes;

  const fem::CoordinateElement cmap(cell_type, 1);
  auto cells = graph::regular_adjacency_list(std::move(raw.cells), nodes_per_cell);
  out.mesh = std::make_shared<mesh::Mesh>(mesh::create_mesh(
      comm, cells, cmap, raw.x, {raw.x.size() / 3, 3}, mesh::GhostMode::shared_facet));

  const int tdim = 3;
  auto& topology = out.mesh->topology_mutable();
  topology.create_connectivity(tdim - 1, tdim);

  // cells: the original (input) index of each local cell gives its marker
  const std::int32_t num_local
      = topology.index_map(tdim)->size_local() + topology.index_map(tdim)->num_ghosts();
  std::vector<std::int32_t> cell_index(num_local), cell_value(num_local);
  for (std::int32_t c = 0; c < num_local; ++c)
  {
    cell_index[c] = c;
    cell_value[c] = raw.cell_marker.at(topology.original_cell_index.at(c));
  }
  out.cell_tags = std::make_shared<mesh::MeshTags<std::int32_t>>(
      out.mesh, tdim, std::move(cell_index), std::move(cell_value));

  // facets: sent to the ranks that own them, identified by input node indices
  const auto [facets, values] = io::xdmf_utils::distribute_entity_data(
      *out.mesh, tdim - 1, raw.facets, raw.facet_marker);
  const int nodes_per_facet = cell_type == mesh::CellType::hexahedron ? 4 : 3;
  out.facet_tags = std::make_shared<mesh::MeshTags<std::int32_t>>(
      mesh::create_meshtags<std::int32_t>(
          out.mesh, tdim - 1,
          graph::regular_adjacency_list(std::vector<std::int32_t>(facets), nodes_per_facet),
          std::span<const std::int32_t>(values)));
  return out;
}

} // namespace muscle
