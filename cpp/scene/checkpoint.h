#pragma once

#include <dolfinx/fem/Function.h>
#include <nlohmann/json.hpp>
#include <string>

namespace muscle
{

/// The last converged state of a run: the displacement at every node (keyed
/// by its coordinates, so a run can resume on any number of ranks) and the
/// run's counters in `state` (time, step, sub-step, ...).
///
/// Files: DIR/checkpoint_STEP.bin, then DIR/checkpoint.json naming it, each
/// written to a temporary name and renamed; the previous binary is removed
/// last -- a run killed at any moment leaves a consistent pair.
void write_checkpoint(const dolfinx::fem::Function<double>& u, const std::string& directory,
                      const nlohmann::json& state);

/// Read DIR/checkpoint.json and set u from DIR/checkpoint.bin (collective).
/// InputError if there is no usable checkpoint or a node of u is not in it.
nlohmann::json read_checkpoint(dolfinx::fem::Function<double>& u, const std::string& directory);

} // namespace muscle
