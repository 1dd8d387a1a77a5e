// gtest main for all test binaries: MPI and PETSc up, DOLFINx logging quiet.
#include <dolfinx/common/log.h>
#include <gtest/gtest.h>
#include <petscsys.h>

#include <common/application.h>

int main(int argc, char** argv)
{
  ::testing::InitGoogleTest(&argc, argv);
  muscle::make_partitions_reproducible();
  PetscInitialize(&argc, &argv, nullptr, nullptr);
  loguru::g_stderr_verbosity = loguru::Verbosity_WARNING;
  const int status = RUN_ALL_TESTS();
  PetscFinalize();
  return status;
}
