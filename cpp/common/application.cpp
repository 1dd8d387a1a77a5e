#include "common/application.h"

#include <chrono>
#include <cstdlib>
#include <thread>

#include "common/errors.h"

#include <cctype>
#include <cmath>
#include <dolfinx/common/log.h>
#include <iostream>
#include <mpi.h>
#include <petscsys.h>

namespace muscle
{

namespace
{
/// Did every rank leave the program body (within a few seconds)?  A rank that
/// stopped with an error alone prints its own message first.
bool all_ranks_stopped()
{
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  if (size == 1)
    return true;
  MPI_Request request;
  MPI_Ibarrier(MPI_COMM_WORLD, &request);
  for (int k = 0; k < 500; ++k) // 5 s
  {
    int done = 0;
    MPI_Test(&request, &done, MPI_STATUS_IGNORE);
    if (done)
      return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}
} // namespace

void throw_if_any(MPI_Comm comm, const std::string& message)
{
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  int mine = message.empty() ? size : rank, first = size;
  MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, comm);
  if (first == size)
    return;
  std::string text = message;
  int length = text.size();
  MPI_Bcast(&length, 1, MPI_INT, first, comm);
  text.resize(length);
  MPI_Bcast(text.data(), length, MPI_CHAR, first, comm);
  throw InputError(text);
}

bool is_root()
{
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  return rank == 0;
}

std::vector<std::string> split_petsc_options(int argc, char** argv,
                                             std::vector<std::string>* petsc)
{
  std::vector<std::string> own;
  auto is_petsc_name = [](const std::string& a)
  {
    return a.size() > 2 and a[0] == '-' and a[1] != '-'
           and std::isalpha(static_cast<unsigned char>(a[1]))
           and std::isalpha(static_cast<unsigned char>(a[2]));
  };
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    if (!is_petsc_name(a))
    {
      own.push_back(a);
      continue;
    }
    if (petsc)
      petsc->push_back(a);
    // a value follows unless the next word is an option itself
    if (i + 1 < argc)
    {
      const std::string next = argv[i + 1];
      const bool option = next.size() > 1 and next[0] == '-'
                          and !std::isdigit(static_cast<unsigned char>(next[1]))
                          and next[1] != '.';
      if (!option)
      {
        if (petsc)
          petsc->push_back(next);
        ++i;
      }
    }
  }
  return own;
}

std::vector<double> parse_range(const std::string& text, const std::string& what)
{
  const std::string usage = what + " '" + text
                            + "': expected START:STOP:COUNT, e.g. 0.7:1.3:13";
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (std::size_t pos; (pos = text.find(':', start)) != std::string::npos;
       start = pos + 1)
    parts.push_back(text.substr(start, pos - start));
  parts.push_back(text.substr(start));
  if (parts.size() != 3)
    throw InputError(usage);
  auto number = [&](const std::string& s, const char* name)
  {
    const auto v = parse_real(s);
    if (!v)
      throw InputError(usage + " (" + name + " '" + s + "' is not a number)");
    return *v;
  };
  const double a = number(parts[0], "START"), b = number(parts[1], "STOP");
  const double n = number(parts[2], "COUNT");
  if (n < 1 or n != std::floor(n) or n > 100000)
    throw InputError(usage + " (COUNT must be a whole number from 1 to 100000)");
  std::vector<double> values;
  const int count = static_cast<int>(n);
  for (int i = 0; i < count; ++i)
    values.push_back(count == 1 ? a : a + (b - a) * i / (count - 1));
  return values;
}

void make_partitions_reproducible()
{
  setenv("SCOTCH_PTHREAD_NUMBER", "1", 0); // the user's value wins
}

int run_application(int argc, char** argv,
                    const std::function<int(std::vector<std::string>)>& body)
{
  make_partitions_reproducible();
  PetscInitialize(&argc, &argv, nullptr, nullptr);
  loguru::g_stderr_verbosity = loguru::Verbosity_WARNING;
  int status = exit_ok;
  std::string message;
  try
  {
    status = body(split_petsc_options(argc, argv));
  }
  catch (const InputError& e)
  {
    message = std::string("error: ") + e.what();
    status = exit_input_error;
  }
  catch (const SolveError& e)
  {
    message = std::string("solve failed: ") + e.what();
    status = exit_solve_error;
  }
  catch (const std::exception& e)
  {
    message = std::string("internal error: ") + e.what();
    status = exit_internal_error;
  }
  if (status != exit_ok)
  {
    if (is_root() and !message.empty())
      std::cerr << message << std::endl;
    if (!all_ranks_stopped())
    {
      // an error on this rank only: the others would wait in a collective
      // for ever, so the whole job stops (mpirun passes the status on)
      if (!is_root() and !message.empty())
        std::cerr << message << std::endl;
      MPI_Abort(MPI_COMM_WORLD, status);
    }
  }
  PetscFinalize();
  return status;
}

} // namespace muscle
