#include "scene/checkpoint.h"

#include "common/errors.h"

#include <cmath>
#include <cstdio>
#include <dolfinx/common/MPI.h>
#include <filesystem>
#include <fstream>
#include <map>

using namespace dolfinx;

namespace muscle
{
namespace
{
/// Node coordinates rounded to 1e-7 mm: dof coordinates of quadratic elements
/// are computed cell by cell and may differ in the last bits between ranks.
using Key = std::array<long long, 3>;
Key key(const double* x)
{
  return {std::llround(x[0] * 1e7), std::llround(x[1] * 1e7), std::llround(x[2] * 1e7)};
}

constexpr std::int64_t magic = 0x4d55534c45434b32; // "MUSLECK2"
} // namespace

void write_checkpoint(const std::vector<std::shared_ptr<fem::Function<double>>>& fields,
                      const std::string& directory, const nlohmann::json& state)
{
  const auto& V = *fields.at(0)->function_space();
  const std::int64_t n_fields = fields.size();
  const int bs = V.dofmap()->index_map_bs();
  const std::int32_t owned = V.dofmap()->index_map->size_local();
  const std::vector<double> x = V.tabulate_dof_coordinates(false);

  // node records: x, y, z, then bs values of each field
  std::vector<double> local;
  local.reserve(owned * (3 + bs * n_fields));
  for (std::int32_t i = 0; i < owned; ++i)
  {
    local.insert(local.end(), x.begin() + 3 * i, x.begin() + 3 * i + 3);
    for (const auto& f : fields)
    {
      std::span<const double> values = f->x()->array();
      local.insert(local.end(), values.begin() + bs * i, values.begin() + bs * (i + 1));
    }
  }
  MPI_Comm comm = V.mesh()->comm();
  const int size = dolfinx::MPI::size(comm), rank = dolfinx::MPI::rank(comm);
  int count = local.size();
  std::vector<int> counts(size), offsets(size + 1, 0);
  MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm);
  for (int r = 0; r < size; ++r)
    offsets[r + 1] = offsets[r] + counts[r];
  std::vector<double> all(rank == 0 ? offsets[size] : 0);
  MPI_Gatherv(local.data(), count, MPI_DOUBLE, all.data(), counts.data(), offsets.data(),
              MPI_DOUBLE, 0, comm);
  if (rank != 0)
    return;

  // the binary of step k has its own name; the JSON naming it is renamed into
  // place last, and only then are older binaries removed: a kill at any moment
  // leaves one consistent pair, and the next checkpoint removes what such a
  // kill left behind
  const std::int64_t step = state.at("step").get<std::int64_t>();
  const std::string name = "checkpoint_" + std::to_string(step) + ".bin";
  const std::string bin = directory + "/" + name, json = directory + "/checkpoint.json";
  {
    std::ofstream out(bin + ".tmp", std::ios::binary);
    const std::int64_t header[4] = {magic, bs, state.at("step").get<std::int64_t>(), n_fields};
    out.write(reinterpret_cast<const char*>(header), sizeof header);
    out.write(reinterpret_cast<const char*>(all.data()), all.size() * sizeof(double));
    if (!out)
      throw std::runtime_error("cannot write " + bin + ".tmp");
  }
  std::filesystem::rename(bin + ".tmp", bin);
  nlohmann::json with_name = state;
  with_name["binary"] = name;
  std::ofstream(json + ".tmp") << with_name.dump(1) << "\n";
  std::filesystem::rename(json + ".tmp", json);
  for (const auto& entry : std::filesystem::directory_iterator(directory))
  {
    const std::string file = entry.path().filename().string();
    const bool binary = file.starts_with("checkpoint_")
                        and (file.ends_with(".bin") or file.ends_with(".bin.tmp"));
    if (binary and file != name)
      std::filesystem::remove(entry.path());
  }
}

nlohmann::json read_checkpoint(const std::vector<std::shared_ptr<fem::Function<double>>>& fields,
                               const std::string& directory)
{
  const std::string json = directory + "/checkpoint.json";
  if (!std::filesystem::exists(json))
    throw InputError("--resume: no checkpoint in " + directory
                     + " (checkpoint.json and checkpoint_STEP.bin are written after every "
                       "converged step; run without --resume to start afresh)");
  nlohmann::json state;
  try
  {
    state = nlohmann::json::parse(std::ifstream(json));
  }
  catch (const std::exception& e)
  {
    throw InputError(json + ": unreadable checkpoint (" + e.what() + ")");
  }
  const std::string bin = directory + "/" + state.value("binary", "checkpoint.bin");
  if (!std::filesystem::exists(bin))
    throw InputError("--resume: " + bin + " named by " + json + " is missing");
  const auto& V = *fields.at(0)->function_space();
  const int bs = V.dofmap()->index_map_bs();
  const std::int64_t n_fields = fields.size();
  std::ifstream in(bin, std::ios::binary);
  std::int64_t header[4] = {0, 0, 0, 0};
  in.read(reinterpret_cast<char*>(header), sizeof header);
  if (!in or header[0] != magic or header[1] != bs
      or header[2] != state.at("step").get<std::int64_t>())
    throw InputError(bin + ": does not match " + json + " (a run killed while writing, or "
                     "written by an older version?)");
  if (header[3] != n_fields)
    throw InputError(bin + ": holds " + std::to_string(header[3]) + " fields per node, this "
                     "scene needs " + std::to_string(n_fields) + " (was dynamics added or "
                     "removed?)");
  std::vector<double> all;
  for (double v; in.read(reinterpret_cast<char*>(&v), sizeof v);)
    all.push_back(v);
  const std::size_t record = 3 + bs * n_fields;
  std::map<Key, std::size_t> index;
  for (std::size_t i = 0; i + record <= all.size(); i += record)
    index[key(&all[i])] = i + 3;

  const std::vector<double> x = V.tabulate_dof_coordinates(false);
  const std::size_t nodes = fields[0]->x()->array().size() / bs;
  std::int64_t missing = 0;
  for (std::size_t i = 0; i < nodes; ++i)
  {
    auto it = index.find(key(&x[3 * i]));
    if (it == index.end())
    {
      ++missing;
      continue;
    }
    for (std::int64_t f = 0; f < n_fields; ++f)
    {
      std::span<double> values = fields[f]->x()->mutable_array();
      for (int c = 0; c < bs; ++c)
        values[bs * i + c] = all[it->second + f * bs + c];
    }
  }
  std::int64_t total = 0;
  MPI_Allreduce(&missing, &total, 1, MPI_INT64_T, MPI_SUM, V.mesh()->comm());
  if (total > 0)
    throw InputError(bin + ": " + std::to_string(total)
                     + " nodes of this mesh are not in the checkpoint (was the mesh or the "
                       "element degree changed?)");
  for (const auto& f : fields)
    f->x()->scatter_fwd();
  return state;
}

} // namespace muscle
