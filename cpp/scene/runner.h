#pragma once

#include "scene.h"

#include <string>

namespace muscle
{

struct RunOptions
{
  std::string out;            ///< output directory
  bool quiet = false;         ///< no progress lines
  bool resume = false;        ///< continue from out/checkpoint.*
  int measure_assembly = 0;   ///< time this many assemblies before the run
  bool check_only = false;    ///< build everything (mesh, surfaces), solve nothing
  int modes = 0;              ///< > 0: the lowest natural frequencies, then stop
};

/// Build what the scene needs -- and nothing else -- and run it.  Writes
/// series.csv, fields.xdmf, summary.json, checkpoints and surface.json into
/// options.out (pictures are the programs' business, not the library's).  Throws InputError for scene mistakes found
/// on the mesh (unknown surface, ...), SolveError when the time stepping fails
/// (after writing the last converged state).
void run_scene(const Scene& scene, const RunOptions& options);

} // namespace muscle
