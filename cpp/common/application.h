#pragma once

#include <functional>
#include <mpi.h>
#include <string>
#include <vector>

namespace muscle
{

/// Run a program: MPI and PETSc initialised, DOLFINx logging quiet (warnings
/// only), and every error turned into one message on rank 0 and an exit status
/// (InputError 2, SolveError 3, anything else 4).
///
/// `body` receives the arguments that are not PETSc options (see
/// split_petsc_options); PETSc reads its own from the full command line.
int run_application(int argc, char** argv,
                    const std::function<int(std::vector<std::string>)>& body);

/// Makes a rank count's mesh partition the same in every run: PT-Scotch's
/// threads, which race in its coarsening, limited to one unless the user set
/// SCOTCH_PTHREAD_NUMBER.  Two ranks gave three different partitions in four
/// runs of the same mesh, so Krylov counts and the last digits of every result
/// changed from run to run.  Before the first mesh is made (run_application and
/// the test main call it before MPI starts).
void make_partitions_reproducible();

/// Separate PETSc options (a single dash and a name of two or more
/// characters, e.g. -snes_monitor or -ksp_type gmres, with a value if one
/// follows) from the program's own arguments (--long options, -h).
std::vector<std::string> split_petsc_options(int argc, char** argv,
                                             std::vector<std::string>* petsc = nullptr);

/// Is this the MPI rank that prints?
bool is_root();

/// Errors found in one rank's share of the mesh (a cell, a data row) must stop
/// every rank: throws InputError on all ranks if `message` is non-empty on any
/// (the lowest such rank's message).  Collective.
void throw_if_any(MPI_Comm comm, const std::string& message);

/// START:STOP:COUNT -> COUNT equally spaced values (COUNT = 1 gives START).
/// `what` names the option in error messages.
std::vector<double> parse_range(const std::string& text, const std::string& what);

} // namespace muscle
