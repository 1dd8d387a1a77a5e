#pragma once

#include <dolfinx/common/MPI.h>
#include <numeric>
#include <vector>

namespace muscle
{

/// Every rank's `local` entries, concatenated in rank order, on every rank.
template <typename T>
std::vector<T> gather_all(MPI_Comm comm, const std::vector<T>& local)
{
  int size;
  MPI_Comm_size(comm, &size);
  int count = local.size();
  std::vector<int> counts(size), offsets(size + 1, 0);
  MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, comm);
  std::partial_sum(counts.begin(), counts.end(), offsets.begin() + 1);
  std::vector<T> all(offsets.back());
  MPI_Allgatherv(local.data(), count, dolfinx::MPI::mpi_type<T>(), all.data(), counts.data(),
                 offsets.data(), dolfinx::MPI::mpi_type<T>(), comm);
  return all;
}

} // namespace muscle
